"""Servo steps per interpolated side, q = T/Δt_p (Sato et al. §3.2.1)."""

from feedtune.loops.protocols import Loop
from feedtune.objectives.base import Metric


class InterpolationRatio(Metric):
    """q = T/Δt_p [1]: reference interval over sampling period, servo steps per side.

    Continuous in the NLP (Sato's Table 1 is interpolated between its rows); bound it with
    ``min``/``max`` (Table 1 covers 2 ≤ q ≤ 50; beyond, its q = 50 row).
    """

    name = "interpolation_ratio"
    unit = "1"
    description = "Reference interval over sampling period, q = T/Δt_p"
    reference = "Sato et al. §3.2.1, Table 1"

    def supports(self, loop: Loop, options=None):
        return loop.interpolator is not None

    def evaluate(self, loop: Loop, options):
        return loop.interpolator.steps_per_interval
