"""Peaks and crossings of frequency responses, exact between grid points.

A grid alone is exploited by an optimiser: a light resonance slips between points and a
bandwidth is claimed where the true −3 dB point lies lower (DESIGN.md, numerical notes).
So every quantity here is located on a logarithmic grid first and then solved exactly
(bisection to a bracket, then Newton through CasADi's rootfinder). The rootfinder's
derivatives follow from the implicit function theorem, so the NLP sees the exact value of
the true peak or crossing and its exact gradient.

Functions take ``fn(omega) -> expression`` (omega in rad/s, a CasADi symbol or number);
the expressions may depend on the NLP's symbols or be plain numbers.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

#: grid density [points per decade]: 5.9 % spacing, enough to bracket peaks with ζ ≳ 0.02
POINTS_PER_DECADE = 40
_BISECTIONS = 30
_NEWTON = {"abstol": 1e-13, "max_iter": 30, "error_on_fail": False}


def log_grid(band: tuple[float, float]) -> np.ndarray:
    """Logarithmic frequency grid [rad/s] covering ``band``."""
    lo, hi = band
    count = int(np.ceil(np.log10(hi / lo) * POINTS_PER_DECADE)) + 1
    return np.geomspace(lo, hi, count)


def _function(name: str, fn, extra=()):
    """``fn`` of u = ln ω as a CasADi Function of (u, free symbols)."""
    u = ca.MX.sym("log_omega")
    expressions = [fn(ca.exp(u))] + [e(ca.exp(u)) for e in extra]
    free = ca.symvar(ca.veccat(*expressions))
    free = [s for s in free if not ca.is_equal(s, u)]
    return ca.Function(name, [u, *free], expressions), u, free


def first_crossing(fn, band: tuple[float, float], level: float = 0.0, name: str = "crossing"):
    """Smallest ω [rad/s] in ``band`` where ``fn`` falls through ``level``.

    ``fn`` must be above ``level`` at the low end of the band. Returns (ω, found), where
    ``found`` is 1 when a crossing exists on the grid and 0 otherwise (then ω is the top
    of the band).
    """
    f, u, free = _function(name, lambda w: fn(w) - level)
    grid = np.log(log_grid(band))
    values = f.map(len(grid))(ca.DM(grid).T, *free)
    below = values < 0
    # first index below the level: scan from the top so the lowest one wins
    low, high, found = ca.MX(grid[-1]), ca.MX(grid[-1]), ca.MX(0)
    for k in range(len(grid) - 1, 0, -1):
        low = ca.if_else(below[k], grid[k - 1], low)
        high = ca.if_else(below[k], grid[k], high)
        found = ca.if_else(below[k], 1, found)
    for _ in range(_BISECTIONS):
        middle = (low + high) / 2
        above = f(middle, *free) > 0
        low = ca.if_else(above, middle, low)
        high = ca.if_else(above, high, middle)
    refine = ca.rootfinder(name, "newton", f, _NEWTON)
    u_star = ca.if_else(found, refine((low + high) / 2, *free), grid[-1])
    return ca.exp(u_star), found


def peak(fn, band: tuple[float, float], name: str = "peak"):
    """(max of ``fn`` over ω ≥ 0, ω at the maximum [rad/s]).

    The grid maximum is refined by Newton's method on d fn/d ln ω = 0. When the largest
    grid value is at the low end of the band, the maximum is taken at ω → 0 (a response
    that only falls, such as a well-damped loop normalised to unit DC gain).
    """
    u = ca.MX.sym("log_omega")
    value = fn(ca.exp(u))
    slope = ca.jacobian(value, u)
    free = [s for s in ca.symvar(ca.veccat(value, slope)) if not ca.is_equal(s, u)]
    f = ca.Function(name, [u, *free], [value])
    stationary = ca.Function(name + "_slope", [u, *free], [slope])
    grid = np.log(log_grid(band))
    values = f.map(len(grid))(ca.DM(grid).T, *free)
    top = ca.mmax(values)
    u0 = ca.mmax(ca.DM(grid).T * (values == top) + (grid[0] - 1) * (values != top))
    refine = ca.rootfinder(name, "newton", stationary, _NEWTON)
    u_star = refine(u0, *free)
    interior = u0 > grid[0]
    best = ca.fmax(f(u_star, *free), top)  # Newton never reports less than the grid saw
    at_zero = fn(0.0)
    return ca.if_else(interior, best, ca.fmax(at_zero, top)), ca.if_else(interior, ca.exp(u_star), 0)
