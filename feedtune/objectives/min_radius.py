"""Smallest circle radius whose radial error at full speed stays within half a BLU."""

import casadi as ca

from feedtune.objectives.base import Metric
from feedtune.objectives.circle import radius_gain_excess

_BISECTIONS = 60


class MinRadius(Metric):
    """r_min [m]: a root of r·| |H(jV_m/r)| − 1 | = BLU/2, the largest in all practical cases.

    Koren's criterion (eqs 30–32: diametral error within one BLU at the maximum path
    velocity V_m), solved for the loop's own frequency response instead of the leading
    term of eq 28. Reduces to eq 33 where the ω² term dominates and to eq 39 (coefficient
    4^(1/3), see docs/errata.md) at K = 1/(2τ).

    The root is bracketed between r = V_m/C_v (ω at the loop gain, where the error is of
    the order of the following error V_m/C_v ≫ BLU) and r = 10⁴·V_m/C_v (error negligible),
    located by bisection on ln r, and refined by Newton's method through CasADi's
    rootfinder so that its derivatives are exact (implicit function theorem).
    """

    name = "min_radius"
    unit = "m"
    description = "Minimum circle radius at V_m with radial error ≤ BLU/2 (exact)"
    reference = "Koren 1979 eqs 30–33, 38–39"

    def supports(self, loop, options=None):
        return loop.drive.blu is not None and loop.drive.max_velocity is not None

    def evaluate(self, loop, options):
        v, blu = loop.drive.max_velocity, loop.drive.blu
        log_r = ca.MX.sym("log_r")
        radius = ca.exp(log_r)
        excess = radius * ca.fabs(radius_gain_excess(loop, v / radius)) / (blu / 2) - 1  # > 0: too large
        free = [s for s in ca.symvar(excess) if not ca.is_equal(s, log_r)]
        excess_fn = ca.Function("min_radius_excess", [log_r, *free], [excess])
        low = ca.log(v / loop.velocity_constant)
        high = low + ca.log(1e4)
        for _ in range(_BISECTIONS):
            middle = (low + high) / 2
            too_large = excess_fn(middle, *free) > 0
            low = ca.if_else(too_large, middle, low)
            high = ca.if_else(too_large, high, middle)
        refine = ca.rootfinder("min_radius", "newton", excess_fn,
                               {"abstol": 1e-12, "max_iter": 20, "error_on_fail": False})
        return ca.exp(refine((low + high) / 2, *free))
