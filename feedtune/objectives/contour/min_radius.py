"""Smallest radius above which every circle at full speed stays within half a BLU."""

from __future__ import annotations

import math

from feedtune.expr import to_float
from feedtune.lazy import ca, np
from feedtune.loops.frequency import jet_function, replayed
from feedtune.loops.protocols import Loop
from feedtune.loops.twin import OfLoop
from feedtune.objectives.base import Metric
from feedtune.objectives.contour.circle import radius_gain_excess

#: radii scanned, per decade of r, over SPAN decades from V_m/C_v up (ω from C_v down);
#: the symbolic scan (inside the NLP) is coarser than the exact one (reported values)
PER_DECADE_SYMBOLIC, PER_DECADE_EXACT, SPAN = 100, 400, 4
#: bisections of one grid cell (ln-width ln(10)/100) before Newton: 2^-30 of it
_BISECTIONS = 30
#: times the exact scan may grow by SPAN decades when its largest radius still fails
_EXTENSIONS = 3


class MinRadius(Metric):
    """r_min [m]: the smallest r* such that every circle of radius r ≥ r* at the maximum
    velocity V_m has a radial error r·| |H(jV_m/r)| − 1 | ≤ BLU/2.

    Koren's criterion (eqs 30–32: diametral error within one BLU at V_m), on the loop's own
    frequency response instead of the leading term of eq 28. The error need not fall
    monotonically with r: where the ω² and ω⁴ terms of eq 28 have opposite signs it dips
    below BLU/2 and rises above it again, so r_min is the *largest* radius where the
    criterion fails (e.g. K = 38.7 1/s, T = 5.908 ms, τ = 10 ms, BLU = 1 µm, V_m =
    0.333 m/s: the criterion holds on 58.3–91.0 mm, fails up to 162.9 mm; r_min = 162.9 mm).
    Reduces to eq 33 where the ω² term dominates and to eq 39 (coefficient 4^(1/3), see
    docs/errata.md) at K = 1/(2τ).

    Radii are scanned from V_m/C_v (where the error is of the order of the following error
    V_m/C_v ≫ BLU) up SPAN decades.

    * On a loop of numbers (the values a result reports) the value is exact: a scan of
      PER_DECADE_EXACT radii per decade, every local maximum of the error above the
      largest failing radius refined (bounded Brent on ln r) so that no failing band
      narrower than the grid is missed, then Brent's root above the largest failing radius.
    * In the NLP: the largest failing radius of a scan of PER_DECADE_SYMBOLIC radii per
      decade brackets the root (the bracket carries no derivative), bisection narrows it
      and Newton's method through CasADi's rootfinder refines it, so that the derivatives
      are exact (implicit function theorem). A failing band narrower than that grid can
      be missed there; the tuner then sees a gap to the exact value (``model_gap``). Where
      a dip touches BLU/2, r_min jumps: the metric is discontinuous in the gains there.
    """

    name = "min_radius"
    unit = "m"
    description = ("Minimum circle radius above which every circle at V_m has radial error "
                   "≤ BLU/2 (exact)")
    reference = "Koren 1979 eqs 30–33, 38–39"

    def supports(self, loop: Loop, options=None):
        return loop.drive.blu is not None and loop.drive.max_velocity is not None

    def evaluate(self, loop: Loop, options):
        low = ca.log(loop.drive.max_velocity / loop.velocity_constant)
        replay = replayed("min_radius_excess", OfLoop(_excess, loop), 0, log_omega=False)
        if replay is not None:  # a loop of numbers whose structure's Function is built
            excess = replay[0][0]  # the jet: from a structure's third loop on
            jet = excess.derived(("jet",), lambda _: _jet_function(loop))
            return ca.DM(_exact(_vectorised(excess), to_float(low), jet))
        log_r = ca.MX.sym("log_r")
        excess = _excess(loop)(log_r)
        free = [s for s in ca.symvar(ca.veccat(excess, ca.MX(low))) if not ca.is_equal(s, log_r)]
        excess_fn = ca.Function("min_radius_excess", [log_r, *free], [excess])
        if not free:  # a loop of numbers: scalar arithmetic, evaluated faster as SX
            return ca.DM(_exact(_vectorised(excess_fn.expand()), to_float(low)))
        count = PER_DECADE_SYMBOLIC * SPAN
        cell = math.log(10) / PER_DECADE_SYMBOLIC
        grid = low + ca.DM(np.arange(count + 1) * cell).T
        # the scan is scalar arithmetic: expanded to SX it evaluates ~2x faster
        values = excess_fn.expand().map(count + 1)(grid, *free)
        worst = ca.stop_diff(ca.mmax(ca.if_else(values > 0, grid, low)), 1)  # largest failing
        lower, upper = worst, worst + cell
        for _ in range(_BISECTIONS):
            middle = (lower + upper) / 2
            fails = excess_fn(middle, *free) > 0
            lower = ca.if_else(fails, middle, lower)
            upper = ca.if_else(fails, upper, middle)
        refine = ca.rootfinder("min_radius", "newton", excess_fn,
                               {"abstol": 1e-12, "max_iter": 20, "error_on_fail": False})
        return ca.exp(refine((lower + upper) / 2, *free))


def _excess(loop: Loop):
    """ln r ↦ r·| |H(jV_m/r)| − 1 | / (BLU/2) − 1 [1]: positive where a circle of radius r
    [m] at V_m fails."""
    v, blu = loop.drive.max_velocity, loop.drive.blu

    def excess(log_r):
        radius = ca.exp(log_r)
        return radius * ca.fabs(radius_gain_excess(loop, v / radius)) / (blu / 2) - 1

    return excess


def _vectorised(fn: ca.Function):
    """``fn`` of one scalar as a function of a numpy array: evaluated through CasADi's
    buffer, one map per array size (:class:`feedtune.loops.frequency.Mapped`, ≈ 2 µs a
    point for the refinements' scalar calls instead of ≈ 70 µs with DM conversions; the
    same evaluation, so the same bits). A scan maps hundreds of points at once. A
    :class:`~feedtune.loops.frequency.Mapped` (replayed on the loop's twin) is one already."""
    from feedtune.loops.frequency import Mapped

    return fn if isinstance(fn, Mapped) else Mapped(fn)


def _exact(excess, low: float, jet=None) -> float:
    """r_min [m] of a loop of numbers: ``excess(ln r)`` (vectorised) > 0 where a circle of
    radius r fails; ``low`` = ln(V_m/C_v). The scan grows by SPAN decades while its last
    radius fails (a slow loop), up to _EXTENSIONS times, then +∞; NaN
    (reported as null) when even V_m/C_v passes (f_m/C_v of a few units: not a CNC axis).
    With ``jet`` (:class:`~feedtune.loops.frequency.Mapped` of excess, its first and second
    derivatives in ln r) the scan evaluates only the radii :func:`_screened` keeps."""
    from scipy.optimize import brentq, minimize_scalar  # 0.11 s: only for a number

    u = low + np.arange(PER_DECADE_EXACT * SPAN + 1) * math.log(10) / PER_DECADE_EXACT
    values = screened = None if jet is None else _screened(excess, jet, u)
    if screened is None:
        values = excess(u)
        for _ in range(_EXTENSIONS):  # a slow loop: SPAN more decades, until a circle passes
            if values[-1] <= 0:
                break
            u = np.concatenate([u, u[-1] + (u[1:] - u[0])])
            values = np.concatenate([values, excess(u[values.size:])])
        if values[-1] > 0:
            return math.inf
    if values[0] <= 0:
        return math.nan
    worst = u[np.nonzero(values > 0)[0][-1]]
    # a failing band narrower than the grid shows as a local maximum that does not fail
    for i in np.nonzero((values[1:-1] >= values[:-2]) & (values[1:-1] >= values[2:]))[0] + 1:
        if u[i + 1] <= worst:
            continue
        res = minimize_scalar(lambda x: -excess(np.array([x]))[0], bounds=(u[i - 1], u[i + 1]),
                              method="bounded", options={"xatol": 1e-12})
        if -res.fun > 0:
            worst = max(worst, float(res.x))
    above = u > worst  # the scan's own values there: no second pass over the grid
    passing = values[above] <= 0
    if screened is not None:  # NaN: a radius of a cell proven to pass
        passing |= np.isnan(values[above])
    upper = u[above][np.argmax(passing)]
    return math.exp(brentq(lambda x: excess(np.array([x]))[0], worst, upper, xtol=1e-15))


#: grid steps a cell of :func:`_screened` spans: 1/25 of a decade, 0.092 in ln r (a jet at
#: each end reaches 0.046, 0.8 of the 0.058 that the peaks' screen reaches from a grid point)
_CELL = 16
#: rows of fine radii are evaluated in multiples of this many points (a map per length)
_CHUNK = 64


def _screened(excess, jet, u):
    """``excess`` on the radii ``u`` that can decide r_min (issue 15), or None (evaluate
    them all): NaN on the radii of a cell where excess < 0 is proven, +∞ where excess > 0
    is, the values of ``excess`` itself on every other cell and one radius either side.

    A cell is :data:`_CELL` grid steps between two radii where ``jet`` gives excess, its
    slope and curvature in ln r; from each end, over the half cell it reaches (ρ), excess
    stays within f ∓ 2(|f′|·ρ + ½|f″|·ρ²) ∓ 1e-9 (the rise terms doubled as the peaks'
    screen does, :func:`feedtune.loops.frequency._bound`; 1e-9 of excess's scale, BLU/2).
    What :func:`_exact` reads is then the same: the largest failing radius lies in a cell
    that is not proven (its neighbour passes) or at a proven-failing cell's end, a local
    maximum above it whose refinement could fail has a neighbourhood that is not proven
    to pass, and the first passing radius above it is its neighbour; those radii are
    evaluated by ``excess`` itself (a map evaluates each point on its own: the same bits).
    """
    n = u.size - 1
    if n % _CELL:
        return None
    f, slope, curvature = jet.columns(u[::_CELL])
    reach = 0.5 * _CELL * (u[1] - u[0])
    rise = 2 * (np.abs(slope) * reach + 0.5 * np.abs(curvature) * reach**2) + 1e-9
    high, low = f + rise, f - rise
    passes = np.fmax(high[:-1], high[1:]) < 0
    fails = np.fmin(low[:-1], low[1:]) > 0
    if passes[0] or not passes[-1]:  # r_min NaN, or a scan that may grow: all of it
        return None
    # at least one cell is open: one that is not proven passing comes before a passing one
    open_cells = np.flatnonzero(~(passes | fails))
    values = np.append(np.where(np.repeat(fails, _CELL), np.inf, np.nan), np.nan)
    wanted = np.zeros(n + 1, dtype=bool)  # each open cell's radii and one either side
    wanted[np.clip(open_cells[:, None] * _CELL + np.arange(-1, _CELL + 2), 0, n)] = True
    index = np.flatnonzero(wanted)
    rows = -(-index.size // _CHUNK) * _CHUNK
    found = excess(u[np.concatenate([index, np.full(rows - index.size, index[-1])])])
    if np.isnan(found[:index.size]).any():
        return None
    values[index] = found[:index.size]
    return values


def _jet_function(loop: Loop):
    """The excess, its slope and curvature in ln r as one SX Function of (ln r, the
    numbers of ``loop``'s twin), for :func:`_screened`: replayed with two derivatives (the
    twin's MX graph differentiated, then expanded with common subexpressions merged: 322
    and 478 instructions on Koren's continuous and sampled loops, where differentiating
    the expanded excess gives 941 and 1 268)."""
    (f, slope, curvature), _ = replayed("min_radius_excess", OfLoop(_excess, loop), 2,
                                        log_omega=False)
    return jet_function(f.fn, slope.fn, curvature.fn)
