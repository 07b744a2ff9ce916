"""Smallest circle radius whose radial error at full speed stays within half a BLU."""

import casadi as ca

from feedtune.objectives.base import Metric


class MinRadius(Metric):
    """r_min [m]: the largest root of r·| |H(jV_m/r)| − 1 | = BLU/2.

    Koren's criterion (eqs 30–32: diametral error within one BLU at the maximum path
    velocity V_m), solved exactly for the loop's own frequency response instead of the
    leading term of eq 28. Newton's method on ln r, started at a radius where the error is
    negligible, with exact derivatives through the implicit function. Reduces to eq 33 when
    the ω² term dominates and to eq 39 (coefficient 4^(1/3)) at K = 1/(2τ).
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
        re, im = loop.frequency_response(v / radius)
        error = radius * (ca.sqrt(re**2 + im**2) - 1)
        residual = 0.5 * ca.log(error**2 + 1e-300) - ca.log(blu / 2)
        free = [s for s in ca.symvar(residual) if not ca.is_equal(s, log_r)]
        residual_fn = ca.Function("min_radius_residual", [log_r, *free], [residual])
        solver = ca.rootfinder("min_radius", "newton", residual_fn,
                               {"abstol": 1e-12, "max_iter": 60, "error_on_fail": False})
        start = ca.log(10 * v / loop.velocity_constant)  # ω = C_v/10: error small, not lost to rounding
        return ca.exp(solver(start, *free))
