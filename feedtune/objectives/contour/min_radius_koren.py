"""Koren's minimum allowable radius formulas, eq 32 (sampled data) and eq 33 (reference pulse)."""

from feedtune.loops.protocols import Loop
from feedtune.objectives.base import Metric
from feedtune.objectives.contour.radial_error_koren import koren_l


class MinRadiusKoren(Metric):
    """r_min [m] = BLU·L·(T f_m)² (eq 32) or BLU·(2Kτ − 1)(f_m/K)² (eq 33).

    Leading-order formulas; they fall to zero (and below) where L ≤ 0, the regime where
    Koren switches to eq 39 and where :class:`~feedtune.objectives.contour.min_radius.MinRadius`
    gives the exact value.
    """

    name = "min_radius_koren"
    unit = "m"
    description = "Minimum radius by Koren's eq 32 (sampled) or eq 33 (reference pulse)"
    reference = "Koren 1979 eqs 29, 32, 33"

    def supports(self, loop: Loop, options=None):
        d = loop.drive
        return d.time_constant is not None and d.max_pulse_rate is not None and loop.order == 2

    def evaluate(self, loop: Loop, options):
        d = loop.drive
        k, tau, fm = loop.velocity_constant, d.time_constant, d.max_pulse_rate
        if loop.discrete:
            return d.blu * koren_l(k, loop.period, tau) * (loop.period * fm) ** 2
        return d.blu * (2 * k * tau - 1) * (fm / k) ** 2
