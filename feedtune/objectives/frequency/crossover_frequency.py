"""Gain-crossover frequency of the open loop (Bhatia 1971, Ch. IV G)."""

from feedtune.loops.protocols import Loop
from feedtune.objectives.base import Metric
from feedtune.objectives.frequency.frequency_domain import gain_crossover, has_open_loop


class CrossoverFrequency(Metric):
    """ω_c [rad/s]: the lowest ω where |L(jω)| = 1 (a sampled loop: |L(e^{jωT})| = 1, π/T
    when |L| stays above 1 up to the Nyquist frequency)."""

    name = "crossover_frequency"
    unit = "rad/s"
    description = "Lowest frequency where the open-loop gain |L| falls to 1"
    reference = "Bhatia 1971 Ch. IV G (crossover frequency sets the speed of response)"

    def supports(self, loop: Loop, options=None):
        return has_open_loop(loop)

    def evaluate(self, loop: Loop, options):
        return gain_crossover(loop)
