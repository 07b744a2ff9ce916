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
_BISECTIONS = 32  # the bracket shrinks to 2^-32 of a grid step before Newton's method
_GOLDEN_STEPS = 48  # golden-section steps: the bracket of two grid steps shrinks to 1e-10
_NEWTON_STEPS = 2


def _refine_max(f, slope, curvature, free, u0, h, lower, upper):
    """Maximum of f(u) near the best grid point u0 (grid step 2h), in [lower, upper].

    Golden-section search on [u0 − 2h, u0 + 2h] (the neighbouring grid points bound the
    peak), then Newton steps on f′ = 0 kept inside the first bracket: the last one carries
    the implicit-function derivative, so the refined maximum has exact gradients.
    """
    ratio = (np.sqrt(5) - 1) / 2
    a, b = ca.fmax(u0 - 2 * h, lower), ca.fmin(u0 + 2 * h, upper)
    outer_a, outer_b = a, b
    for _ in range(_GOLDEN_STEPS):
        c = b - ratio * (b - a)
        d = a + ratio * (b - a)
        left = f(c, *free) > f(d, *free)
        a, b = ca.if_else(left, a, c), ca.if_else(left, d, b)
    u = (a + b) / 2
    for _ in range(_NEWTON_STEPS):
        g, c = slope(u, *free), curvature(u, *free)
        step = ca.if_else(c < 0, -g / ca.if_else(c < 0, c, -1), 0)
        u = ca.fmin(ca.fmax(u + step, outer_a), outer_b)  # golden section is only as
    return u  # sharp as f's rounding (√eps in u on a flat peak): Newton finishes it


def log_grid(band: tuple[float, float]) -> np.ndarray:
    """Logarithmic frequency grid [rad/s] covering ``band``."""
    lo, hi = band
    count = int(np.ceil(np.log10(hi / lo) * POINTS_PER_DECADE)) + 1
    return np.geomspace(lo, hi, count)


def _functions(name: str, fn, derivatives: int):
    """fn of u = ln ω and its first ``derivatives`` u-derivatives, as CasADi Functions.

    Each takes (u, free symbols of the expression): the loop's symbols when the loop is
    symbolic, none when it is made of numbers.
    """
    u = ca.MX.sym("log_omega")
    expressions = [fn(ca.exp(u))]
    for _ in range(derivatives):
        expressions.append(ca.jacobian(expressions[-1], u))
    free = [v for v in ca.symvar(ca.veccat(*expressions)) if not ca.is_equal(v, u)]
    return [ca.Function(f"{name}_{k}", [u, *free], [e]) for k, e in enumerate(expressions)], free


def first_crossing(fn, band: tuple[float, float], level: float = 0.0, name: str = "crossing"):
    """Smallest ω [rad/s] in ``band`` where ``fn`` falls through ``level``.

    ``fn`` must be above ``level`` at the low end of the band. The lowest grid interval
    where it falls below is bisected to 2⁻³² of its width and finished by Newton steps,
    whose last step carries the implicit-function derivative dω/dp = −(∂f/∂p)/(∂f/∂ω).
    Everything is plain CasADi arithmetic, so the NLP can expand it to SX. Without a
    crossing on the grid, ω is the top of the band.
    """
    (f, slope), free = _functions(name, lambda w: fn(w) - level, 1)
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
    u = (low + high) / 2
    for _ in range(2):
        step = f(u, *free) / slope(u, *free)
        u = u - ca.fmin(ca.fmax(step, low - u), high - u)  # stay inside the bracket
    return ca.exp(ca.if_else(found, u, grid[-1]))


def peak(fn, band: tuple[float, float], name: str = "peak"):
    """Max of ``fn`` over ω ≥ 0.

    The largest grid value is refined by golden-section search between its neighbours and
    Newton steps on d fn/d ln ω = 0, so the peak between grid points is found and its
    derivative is exact (envelope theorem). When the largest grid value is at the low end
    of the band, the maximum is taken at ω → 0 (a response that only falls, such as a
    well-damped loop normalised to unit DC gain).
    """
    (f, slope, curvature), free = _functions(name, fn, 2)
    grid = np.log(log_grid(band))
    h = (grid[1] - grid[0]) / 2
    values = f.map(len(grid))(ca.DM(grid).T, *free)
    top = ca.mmax(values)
    u = ca.mmax(ca.DM(grid).T * (values == top) + (grid[0] - 1) * (values != top))
    interior = u > grid[0]
    u = _refine_max(f, slope, curvature, free, u, h, grid[0], grid[-1])
    best = ca.fmax(f(u, *free), top)  # never less than the grid saw
    at_zero = fn(0.0)
    return ca.if_else(interior, best, ca.fmax(at_zero, top))


def lowest_value(fn, band: tuple, count: int, name: str = "lowest"):
    """min of ``fn`` over ω in ``band`` (CasADi expressions allowed for the band's ends).

    The smallest of a relative grid, refined between its neighbours (golden section, Newton); the band may
    move with the NLP's variables (a bandwidth candidate b).
    """
    lo, hi = band
    x = np.linspace(0.0, 1.0, count)
    u_lo, u_hi = ca.log(lo), ca.log(hi)
    points = [u_lo + xi * (u_hi - u_lo) for xi in x]
    (f, slope, curvature), free = _functions(name, lambda w: -fn(w), 2)
    values = ca.vertcat(*[f(u, *free) for u in points])
    top = ca.mmax(values)
    u = ca.mmax(ca.vertcat(*[ca.if_else(v == top, pt, u_lo - 1) for v, pt in zip(
        ca.vertsplit(values), points)]))
    h = (u_hi - u_lo) / (len(x) - 1) / 2
    u = _refine_max(f, slope, curvature, free, u, h, u_lo, u_hi)
    return -ca.fmax(f(u, *free), top)


def _relative_points(ratio: float) -> int:
    return int(np.ceil(np.log10(ratio) * POINTS_PER_DECADE)) + 1


def relative_grid(band: tuple[float, float]) -> np.ndarray:
    """Points x in (0, 1) so that b·x covers [band low, b) logarithmically."""
    lo, hi = band
    return np.geomspace(lo / hi, 1.0, _relative_points(hi / lo))[:-1]
