"""Damping ratio of a second-order closed loop (Koren eqs 9 and 19)."""

from feedtune.loops.protocols import Loop
from feedtune.objectives.base import Metric


class DampingRatio(Metric):
    """ζ [-]: eq 9 for the continuous loop, eq 19 (equivalent s-plane poles) sampled."""

    name = "damping_ratio"
    unit = "1"
    description = "Damping ratio ζ of the closed-loop pole pair"
    reference = "Koren 1979 eqs 9, 19"

    def supports(self, loop: Loop, options=None):
        return loop.order == 2

    def evaluate(self, loop: Loop, options):
        return loop.damping_ratio()
