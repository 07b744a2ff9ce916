"""Natural frequency of a second-order closed loop (Koren eq 10; eqs 17–18 sampled)."""

from feedtune.loops.protocols import Loop
from feedtune.objectives.base import Metric


class NaturalFrequency(Metric):
    """ω_n [rad/s]: √(K/τ) continuous (eq 10); √((αT)² + (ωT)²)/T sampled (eqs 17–18)."""

    name = "natural_frequency"
    unit = "rad/s"
    description = "Natural frequency ω_n of the closed-loop pole pair"
    reference = "Koren 1979 eqs 10, 17, 18"

    def supports(self, loop: Loop, options=None):
        return loop.order == 2

    def evaluate(self, loop: Loop, options):
        return loop.natural_frequency()
