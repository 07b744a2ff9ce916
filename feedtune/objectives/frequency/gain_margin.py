"""Gain margin of the open loop (Bhatia 1971, Ch. IV F; ≈ 1.2 uncompensated)."""

from feedtune.lazy import ca
from feedtune.loops.frequency import first_crossing
from feedtune.loops.protocols import Loop
from feedtune.objectives.base import Metric
from feedtune.objectives.frequency.frequency_domain import (as_number, has_open_loop,
                                                            phase_crossover_indicator)


class GainMargin(Metric):
    """1/|L(jω_180)| [1] at the lowest phase crossover ω_180 (arg L = −180°).

    A sampled loop's L(e^{jωT}) is real at the Nyquist frequency: when it is negative there
    and the phase has not reached −180° before, ω_180 = π/T (a ZOH loop without delay).
    """

    name = "gain_margin"
    unit = "1"
    description = "Factor by which the open-loop gain may grow before instability (ratio, not dB)"
    reference = "Bhatia 1971 Ch. IV F (gain margin 1.2 of the uncompensated loop)"

    def supports(self, loop: Loop, options=None):
        return has_open_loop(loop)

    def evaluate(self, loop: Loop, options):
        omega = first_crossing(phase_crossover_indicator(loop), loop.frequency_band, 0.0,
                                  "phase_crossover")
        re, im = loop.open_loop_response(as_number(omega))
        return 1 / ca.sqrt(re**2 + im**2)
