"""Peaks and crossings of frequency responses, exact between grid points.

A grid alone is exploited by an optimiser: a light resonance slips between points and a
bandwidth is claimed where the true −3 dB point lies lower (docs/design.md, numerical notes).
So every quantity here is located on a logarithmic grid first and then solved exactly:
crossings by bisection to a bracket then Newton steps, peaks by golden section in every
grid window then Newton steps. The last Newton step carries the implicit-function
derivative, so the exact value of the true peak or crossing has its exact gradient.

Functions take ``fn(omega) -> expression`` (omega in rad/s, a CasADi symbol or number);
the expressions may depend on the NLP's symbols or be plain numbers.
"""

from __future__ import annotations

import functools
import math

from feedtune.buffers import ThreadBuffers
from feedtune.lazy import ca, np
from feedtune.loops.twin import OfLoop, asked_before, parametric_twin
from feedtune.lru import Lru

#: grid density [points per decade]: 5.9 % spacing, enough to bracket peaks with ζ ≳ 0.02
POINTS_PER_DECADE = 40
_BISECTIONS = 32  # the bracket shrinks to 2^-32 of a grid step before Newton's method
#: golden-section steps: the bracket of two grid steps (0.115 in ln ω) shrinks to 0.618²⁰ =
#: 6.6e-5 of it (7.6e-6 in ln ω), well inside a peak of ζ ≳ 0.002 (width ≈ ζ in ln ω), where
#: the two Newton steps converge (error ≲ e²/ζ a step: ≲ 1e-8, then rounding); the 28 more
#: steps of 48 only met f's rounding (values equal to ≤ 3e-12 relative on 180 batch peaks)
_GOLDEN_STEPS = 20
#: golden steps in every window of a loop of numbers before only the windows that can
#: hold the peak go on (:func:`_peak_of_numbers`); the bracket is then 5.6 % of a window
_SCREEN_STEPS = 6
_NEWTON_STEPS = 2
#: requests of a Function derived from a replayed one (:meth:`Mapped.derived`: a peak's
#: golden-section steps, its finish and jet, a crossing's bisections) answered by the float
#: steps before it is built. A build costs ≈ 2–5 ms of CPU (golden 2.1, jet 3.5, crossing
#: 3.9, finish 5.0) and saves ≈ 0.3 ms a crossing, ≈ 2 ms a peak's refinement
#: (benchmarks/README.md, branches h-bev2 and h-tcon7): it pays back after several loops
#: of a structure, not after one more. Built at the third request, a Function that two
#: loops ask for once each builds nothing; a batch builds it at its third spec of a
#: structure instead of its second (the same bits either way).
DERIVED_AFTER = 2


def _refine_windows(f, slope, curvature, free, centres, h, lower, upper):
    """Maxima of f(u) in every window [u_k − 2h, u_k + 2h] ∩ [lower, upper], all at once.

    ``centres`` is a row of grid points u_k (grid step 2h), so each window spans a point's
    two neighbours and every peak of f lies inside one of them. Golden-section search in
    all windows together (``f`` mapped over the row), then Newton steps on f′ = 0 kept
    inside each window: the last one carries the implicit-function derivative, so each
    refined maximum has exact gradients. Returns the rows (values, u).
    """
    count = centres.shape[1]
    f_all, slope_all, curvature_all = (fn.map(count) for fn in (f, slope, curvature))
    ratio = (np.sqrt(5) - 1) / 2
    a, b = ca.fmax(centres - 2 * h, lower), ca.fmin(centres + 2 * h, upper)
    outer_a, outer_b = a, b
    bracket = _golden_steps(f_all, free, count).fold(_GOLDEN_STEPS)(ca.vertcat(a, b), *free)
    a, b = bracket[0, :], bracket[1, :]
    u = (a + b) / 2
    for _ in range(_NEWTON_STEPS):
        g, c = slope_all(u, *free), curvature_all(u, *free)
        step = ca.if_else(c < 0, -g / ca.if_else(c < 0, c, -1), 0)
        u = ca.fmin(ca.fmax(u + step, outer_a), outer_b)  # golden section is only as
    return f_all(u, *free), u  # sharp as f's rounding (√eps in u on a flat peak): Newton finishes it


def _golden_steps(f_all, free, count: int):
    """One golden-section step in every window at once, as a Function of the brackets
    (a row of a over a row of b) and ``free``, whose fold is :func:`_refine_windows`' 48
    steps: one node of the graph, built once, instead of ≈ 10 nodes a step built in
    Python (the same operations in the same order, so the same bits)."""
    ratio = (np.sqrt(5) - 1) / 2
    bracket = ca.MX.sym("bracket", 2, count)
    a, b = bracket[0, :], bracket[1, :]
    c = b - ratio * (b - a)
    d = a + ratio * (b - a)
    left = f_all(c, *free) > f_all(d, *free)
    return ca.Function("golden_step", [bracket, *free],
                       [ca.vertcat(ca.if_else(left, a, c), ca.if_else(left, d, b))])


def _best(values, u):
    """(largest of a row of values, the u where it is taken)."""
    top = ca.mmax(values)
    return top, ca.mmax(u * (values == top) + (ca.mmin(u) - 1) * (values != top))


def log_grid(band: tuple[float, float]) -> np.ndarray:
    """Logarithmic frequency grid [rad/s] covering ``band`` (a copy of the grid kept for
    the band: :func:`_grids`)."""
    return _grids(float(band[0]), float(band[1]))[0].copy()


@functools.lru_cache(maxsize=256)
def _grids(lo: float, hi: float) -> tuple:
    """(ω grid [rad/s], its ln ω [ln(rad/s)]) of the band [lo, hi], both read-only, kept
    per band (issue 15): a tuned design's reports ask for the grid of one band ≈ 8 times
    (each peak and crossing, the suprema, the bandwidth's count), and ``np.geomspace``
    costs ≈ 50–100 µs a call. The arrays are those computed once, so the same bits."""
    count = int(np.ceil(np.log10(hi / lo) * POINTS_PER_DECADE)) + 1
    grid = np.geomspace(lo, hi, count)
    logs = np.log(grid)
    grid.flags.writeable = logs.flags.writeable = False
    return grid, logs


def _log_of_grid(band: tuple[float, float]) -> np.ndarray:
    """``np.log(log_grid(band))`` [ln(rad/s)], read-only (kept per band: :func:`_grids`)."""
    return _grids(float(band[0]), float(band[1]))[1]


def lattice_band(band: tuple[float, float]) -> tuple[float, float]:
    """``band`` [rad/s] widened to the points 10^(k/40) around it (40 = POINTS_PER_DECADE),
    the low one at an even k, so that :func:`log_grid` of it is those points.

    A loop whose band is widened so keeps its grid's points, and the tuner's rows on every
    other point, at the same frequencies when a band end moves (a changed corner or box).
    Spread evenly from the low end to the high one, every point moved with either end;
    measured on ``examples/user-defined-pid-notch.json`` (one start, from its initial
    point): 66 IPOPT iterations to 1741.27 rad/s on (0.1, 1e8) rad/s (lattice points), 558
    to another optimum on (0.1, 2e7), 98 on (0.1, 3e7); on this lattice 68–76 to 1741.27
    for bands ending at 2e7 or 3e7 and starting at 0.05 or 0.1 (which rows miss the
    resonance decides IPOPT's path).
    """
    k_lo = 2 * math.floor(math.log10(band[0]) * POINTS_PER_DECADE / 2 + 1e-9)
    k_hi = math.ceil(math.log10(band[1]) * POINTS_PER_DECADE - 1e-9)
    lo = 10.0 ** (k_lo / POINTS_PER_DECADE)
    hi = lo * 10.0 ** ((k_hi - k_lo) / POINTS_PER_DECADE)
    while math.ceil(math.log10(hi / lo) * POINTS_PER_DECADE) > k_hi - k_lo:  # rounding
        hi = math.nextafter(hi, 0.0)
    return lo, hi


#: "SX"/"MX" → (u, ω = e^u): the process's one ln ω symbol of each kind, on which every
#: peak and crossing builds its Functions
_LOG_OMEGA: dict[str, tuple] = {}


def _log_omega(kind: str) -> tuple:
    """(u, ω = e^u) of the ``kind`` ("SX" or "MX") shared by every Function built here: a
    loop builds its responses at this ω once (``feedtune.loops.loop.at_shared_omega``), and
    the peaks and crossings of one loop (|T|² for M_peak and the bandwidth, L for the
    margins and the crossover) read the same expression. A Function of a shared
    expression is the Function of a fresh one (the same operations), so the same bits."""
    if kind not in _LOG_OMEGA:
        u = getattr(ca, kind).sym("log_omega")
        _LOG_OMEGA[kind] = (u, ca.exp(u))
    return _LOG_OMEGA[kind]


def is_shared_omega(omega) -> bool:
    """Whether ``omega`` is the ω of :func:`_log_omega` (the object itself)."""
    return any(omega is shared for _, shared in _LOG_OMEGA.values())


def _with_derivatives(expression, u, derivatives: int) -> list:
    """[``expression``, its first ``derivatives`` derivatives in the scalar symbol ``u``]."""
    expressions = [expression]
    for _ in range(derivatives):
        expressions.append(ca.jacobian(expressions[-1], u))
    return expressions


def _functions(name: str, fn, derivatives: int):
    """fn of u = ln ω and its first ``derivatives`` u-derivatives, as CasADi Functions.

    Each takes (u, free symbols of the expression): the loop's symbols when the loop is
    symbolic, none when it is made of numbers. Each is expanded to SX where it can be
    (:func:`_expanded`): the peaks and crossings call them ≈ 100 times over the grid, and
    an SX Function evaluates, and builds its derivatives, several times faster than the
    MX graph of the loop's response (the same operations; ``benchmarks/README.md``,
    branch h-tmc).
    """
    u, omega = _log_omega("MX")
    expressions = _with_derivatives(fn(omega), u, derivatives)
    free = [v for v in ca.symvar(ca.veccat(*expressions)) if not ca.is_equal(v, u)]
    return [_expanded(ca.Function(f"{name}_{k}", [u, *free], [e]))
            for k, e in enumerate(expressions)], free


def _number_functions(name: str, fn, derivatives: int):
    """:func:`_functions` for a loop of numbers, built in SX directly (issue 15), or None.

    The same Python operations on an SX symbol give the SX graph that expanding the MX
    Functions gives (expansion evaluates each MX operation on SX, constants folded by the
    same double operations): the same bits for f, f′ and f″ on the bundled loops
    (tests/unit/test_peak_numbers.py, test_first_crossing_numbers.py), without the MX graph,
    its jacobians and the expansion (≈ 2.5 ms a call). None where ``fn`` cannot take an SX
    argument (a loop holding MX: symbols inside the NLP, or MX matrices of numbers).
    """
    u, omega = _log_omega("SX")
    try:
        expressions = _with_derivatives(ca.SX(fn(omega)), u, derivatives)
    except (TypeError, NotImplementedError, RuntimeError):
        return None
    if any(not ca.is_equal(v, u) for v in ca.symvar(ca.veccat(*expressions))):
        return None
    return [ca.Function(f"{name}_{k}", [u], [e]) for k, e in enumerate(expressions)]


def first_crossing(fn, band: tuple[float, float], level: float = 0.0, name: str = "crossing"):
    """Smallest ω [rad/s] in ``band`` where ``fn`` falls through ``level``.

    ``fn`` must be above ``level`` at the low end of the band. The lowest grid interval
    where it falls below is bisected to 2⁻³² of its width and finished by Newton steps,
    whose last step carries the implicit-function derivative dω/dp = −(∂f/∂p)/(∂f/∂ω).
    Everything is plain CasADi arithmetic, so the NLP can expand it to SX. Without a
    crossing on the grid, ω is the top of the band (:func:`crossing_if_any` also says
    whether there was one).
    """
    return crossing_if_any(fn, band, level, name)[0]


def crossing_if_any(fn, band: tuple[float, float], level: float = 0.0,
                    name: str = "crossing") -> tuple:
    """(ω, found): :func:`first_crossing`'s ω [rad/s], and whether ``fn`` falls through
    ``level`` on the band's grid (1, else 0 and ω is the top of the band); both
    expressions of the loop's symbols, or of numbers."""
    grid = _log_of_grid(band)
    replay = replayed(name, fn, 1, level)
    if replay is not None:  # a loop of numbers whose structure's Functions are built
        f, slope = replay[0]
        return _as_expressions(_first_crossing_of_numbers(f, slope, grid, f(grid)))
    numbers = _number_functions(name, lambda w: fn(w) - level, 1)
    if numbers is not None:  # a loop of numbers: the same steps in floats, no graph to build
        f, slope = (Mapped(g) for g in numbers)
        return _as_expressions(_first_crossing_of_numbers(f, slope, grid, f(grid)))
    (f, slope), free = _functions(name, lambda w: fn(w) - level, 1)
    if not free:  # a loop of numbers: the same steps in floats, without a graph to build
        f, slope = Mapped(f), Mapped(slope)
        return _as_expressions(_first_crossing_of_numbers(f, slope, grid, f(grid)))
    values = f.map(len(grid))(ca.DM(grid).T, *free)
    low, high, found = _first_interval_below(values, grid)
    bracket = _bisection_step(f, free).fold(_BISECTIONS)(ca.vertcat(low, high), *free)
    low, high = bracket[0], bracket[1]
    u = (low + high) / 2
    for _ in range(2):
        g = slope(u, *free)
        # no step where f is flat (a sampled loop's crossing cut at π/T, which the
        # bisection already holds to 2^-32 of a grid step)
        step = ca.if_else(g != 0, f(u, *free) / ca.if_else(g != 0, g, 1), 0)
        u = u - ca.fmin(ca.fmax(step, low - u), high - u)  # stay inside the bracket
    return ca.exp(ca.if_else(found, u, grid[-1])), found


def _bisection_step(f, free):
    """One bisection step of :func:`crossing_if_any` as a Function of the bracket
    [low, high] and ``free``, whose fold is the 32 steps (one node instead of five a step
    built in Python; the same operations, so the same bits)."""
    bracket = ca.MX.sym("bracket", 2)
    low, high = bracket[0], bracket[1]
    middle = (low + high) / 2
    above = f(middle, *free) > 0
    return ca.Function("bisection_step", [bracket, *free],
                       [ca.vertcat(ca.if_else(above, middle, low), ca.if_else(above, high, middle))])


def _first_interval_below(values, grid: np.ndarray) -> tuple:
    """(grid[k − 1], grid[k], 1) for the lowest k ≥ 1 with ``values[k]`` < 0, else
    (grid[-1], grid[-1], 0): MX expressions of a row of values on the increasing ``grid``.

    The smallest grid point (and its left neighbour) among those whose value is below 0,
    taken on the whole row at once: the same selection as a scan from the top of one
    ``if_else`` per grid point, without its ≈ 3 nodes and one element read per point,
    whose reverse derivative (CasADi's ``jacobian`` of a scalar) costs a row-sized node per
    read (0.2–0.4 s a crossing on the metric contract's loops; branch h-tmc)."""
    below = values[1:] < 0
    found = ca.mmax(below)
    row = ca.DM(grid).T
    low = ca.if_else(found, ca.mmin(ca.if_else(below, row[:-1], ca.inf)), grid[-1])
    high = ca.if_else(found, ca.mmin(ca.if_else(below, row[1:], ca.inf)), grid[-1])
    return low, high, found


def _as_expressions(located: tuple[float, bool]) -> tuple:
    """(ω, found) of :func:`_first_crossing_of_numbers` as numbers (DM) that the metrics'
    CasADi arithmetic takes as it takes the MX of a loop of numbers: DM operations are
    the same IEEE operations, evaluated at once instead of as a graph evaluated later."""
    return ca.DM(located[0]), ca.DM(float(located[1]))


def _first_crossing_of_numbers(f, slope, grid: np.ndarray, values: np.ndarray) -> tuple:
    """:func:`first_crossing` for a function of ln ω without free symbols: the lowest grid
    interval whose upper end is below 0, bisected and finished by Newton steps exactly as
    the symbolic version does, in floats (building its graph of ≈ 3 if_else nodes per grid
    point cost 0.1 s a call on Bhatia's loop); ``f`` and ``slope`` are :class:`Mapped`
    (SX-expanded, evaluated through CasADi's buffer). Returns (ω [rad/s], whether ``f``
    falls below 0 on the grid)."""
    below = np.flatnonzero(values[1:] < 0)
    if below.size == 0:
        return math.exp(grid[-1]), False
    k = int(below[0]) + 1
    refined = f.derived(("crossing", _BISECTIONS), _crossing_function, (slope.fn,))
    if refined is not None:  # bisections and Newton steps in one call (issue 15)
        (u,) = refined.columns(np.array([[grid[k - 1]], [grid[k]]]))
        return math.exp(float(u[0])), True
    low, high = _bisections_of_numbers(f, float(grid[k - 1]), float(grid[k]))
    u = (low + high) / 2
    for _ in range(2):
        g = float(slope(u)[0])
        step = float(f(u)[0]) / g if g != 0 else 0.0  # as the symbolic version
        u = u - float(np.fmin(np.fmax(step, low - u), high - u))  # as ca.fmin/ca.fmax
    return math.exp(u), True


def _bisections_of_numbers(f, low: float, high: float) -> tuple[float, float]:
    """:data:`_BISECTIONS` bisection steps of [low, high] on ``f`` (a :class:`Mapped`),
    keeping the half whose lower end has f > 0: through :func:`_bisection_function`
    kept with ``f`` where :meth:`Mapped.derived` gives it, else step by step in floats
    (the same operations, so the same bits)."""
    bisection = f.derived(("bisection", _BISECTIONS),
                          lambda fn: _bisection_function(fn, _BISECTIONS))
    if bisection is not None:
        (bracket,) = bisection.columns(np.array([[low], [high]]))
        return float(bracket[0, 0]), float(bracket[1, 0])
    for _ in range(_BISECTIONS):
        middle = (low + high) / 2
        if f(middle)[0] > 0:
            low = middle
        else:
            high = middle
    return low, high


def _bisection_function(f, steps: int):
    """``steps`` bisection steps as one Function of the bracket [low, high] and ``f``'s
    fixed inputs (issue 15): :func:`_bisection_step` on a Function of numbers, its step
    expanded to SX and folded, instead of one Python round and one call a step."""
    fixed = _inputs_after_first(f)
    return _folded(_bisection_step(f, fixed), steps, f"bisection_{steps}", fixed)


def _crossing_function(f, slope):
    """:func:`_first_crossing_of_numbers`' refinement of a bracket as one SX Function of
    the bracket [low, high] [ln(rad/s)] and ``f``'s fixed inputs → u [ln(rad/s)]: the
    :data:`_BISECTIONS` folded bisection steps (:func:`_bisection_function`), then the two
    Newton steps of :func:`crossing_if_any` kept inside the bracket. The same IEEE
    operations as the float steps (a division where f′ ≠ 0, fmin/fmax as C's), so the
    same bits, in one call instead of five."""
    fixed = _inputs_after_first(f)
    bracket = ca.MX.sym("bracket", 2)
    state = _bisection_function(f, _BISECTIONS)(bracket, *fixed)
    low, high = state[0], state[1]
    u = (low + high) / 2
    for _ in range(2):
        g = slope(u, *fixed)
        step = ca.if_else(g != 0, f(u, *fixed) / ca.if_else(g != 0, g, 1), 0)
        u = u - ca.fmin(ca.fmax(step, low - u), high - u)
    return ca.Function(f"crossing_{_BISECTIONS}", [bracket, *fixed], [u]).expand()


def _folded(step, steps: int, name: str, fixed: list):
    """``steps`` repetitions of ``step`` (a Function of a state column and ``fixed``,
    giving the next state) as one SX Function of (the state, ``fixed``): the step
    expanded to SX, folded, and the fold expanded into one straight SX graph (no call a
    step: 42 golden steps of a window in 0.6× the fold's time, built in ≈ 4 ms once per
    structure; the same operations on the same numbers, so the same bits)."""
    start = ca.MX.sym("state", step.sparsity_in(0))
    repeated = [ca.repmat(x, 1, steps) for x in fixed]  # the fold reads one column a step
    return ca.Function(name, [start, *fixed],
                       [step.expand().fold(steps)(start, *repeated)]).expand()


def peak(fn, band: tuple[float, float], name: str = "peak"):
    """(max of ``fn`` over ω ≥ 0, the ω [rad/s] where it is taken; 0 for ω → 0).

    Every grid window is refined (golden section and Newton steps on d fn/d ln ω = 0), and
    the largest refined value wins: a light resonance whose grid points sit low is not
    beaten by a broad peak that the grid happens to see well. The derivative is exact
    (envelope theorem). Below the band the value at ω = 0 stands for the response.
    """
    logs = _log_of_grid(band)
    h = float(logs[1] - logs[0]) / 2
    replay = replayed(name, fn, 2, at_zero=True)
    if replay is not None:  # a loop of numbers whose structure's Functions are built
        (f, slope, curvature), at_zero = replay
        best = _peak_of_numbers(f, slope, curvature, logs, h)
        if best is not None:  # numbers (DM): the same operations as the MX below, done now
            return _peak_numbers(*best, at_zero)
    numbers, symbolic = _number_functions(name, fn, 2), None
    if numbers is None:
        symbolic = _functions(name, fn, 2)
        numbers = None if symbolic[1] else symbolic[0]
    best = None if numbers is None else _peak_of_numbers(
        *(Mapped(g) for g in numbers), logs, h)
    if best is not None:  # a loop of numbers: the same steps in floats, no graph to build
        top, u = (ca.MX(v) for v in best)
    else:  # the symbolic path, on the MX graph (it also decides where a number is NaN)
        grid = ca.DM(logs).T
        (f, slope, curvature), free = symbolic or _functions(name, fn, 2)  # built once
        values, u = _refine_windows(f, slope, curvature, free, grid, h, grid[0], grid[-1])
        top, u = _best(ca.horzcat(values, f.map(grid.shape[1])(grid, *free)),
                       ca.horzcat(u, grid))
    at_zero = fn(0.0)
    return ca.fmax(top, at_zero), ca.if_else(at_zero >= top, 0.0, ca.exp(u))


def _peak_numbers(top: float, u: float, at_zero: float) -> tuple:
    """(fmax(top, at_zero), 0 where at_zero ≥ top else e^u) as DM numbers: :func:`peak`'s
    last operations on the floats of a replayed refinement, each the IEEE operation (or
    the C library's ``exp``) that CasADi's DM operation performs, so the same bits without
    ≈ 10-20 µs of CasADi's call an operation. NaN never reaches here (the refinement
    returns None), so fmax is the larger of the two (``top`` where they are equal)."""
    value = top if top >= at_zero else at_zero
    return ca.DM(value), ca.DM(0.0 if at_zero >= top else math.exp(u))


def _expanded(fn):
    """``fn`` expanded to SX (its constants folded once, by the same double operations),
    or ``fn`` itself where it is SX already or does not expand."""
    if fn.is_a("SXFunction"):
        return fn
    try:
        return fn.expand()
    except RuntimeError:
        return fn


def _peak_of_numbers(f, slope, curvature, grid: np.ndarray, h: float):
    """:func:`peak`'s refinement and choice for a function of ln ω without free symbols:
    :func:`_refine_windows` and :func:`_best` step for step in numpy floats, each
    elementwise operation the IEEE operation CasADi's graph performs (golden-section
    points, comparisons, fmin/fmax, Newton steps), and ``f``, ``f′``, ``f″`` the same
    CasADi Functions (SX-expanded) mapped over the row (:class:`Mapped`, of the loop's
    own graph or replayed on its twin: :func:`replayed`). Building that graph (then 48
    golden steps, ≈ 10 nodes each, over the whole grid) cost ≈ 70 ms a call on Bhatia's loop.

    Only the windows that can hold the largest value are refined to the end (issue 15):
    a window takes the golden steps only if :func:`_window_bound` (what its refinement can
    still reach) on the whole window is at least the largest grid value, which the choice
    takes among its candidates, so the top is never below it, or if a neighbour's is (a
    peak near a window's edge is also its neighbour's, and the bound read at the centre of
    a whole window fell short of it on 4 of 300 batch specs: the top moved by rounding);
    after :data:`_SCREEN_STEPS` steps the same bound on its narrowed bracket decides
    whether it goes on to the end. On the batch benchmark's loops the first screen passes
    4–15 of 174–565 windows; a refinement (its Functions' expansion included) took 4.2
    instead of 5.0 ms, with the same results on 1 200 loops at random points of the 300
    specs' boxes.
    Every window kept is refined by the same operations on the same numbers (a mapped
    Function evaluates each element on its own), so the top and its ln ω are those of
    refining every window, bit for bit.

    Returns (largest value, the ln ω where it is taken), or None if any value is NaN
    (the symbolic path then decides, as before: its max and comparisons treat NaN its
    own way).
    """
    jet = f.derived(("jet",), jet_function, (slope.fn, curvature.fn))
    if jet is None:
        f_grid, at_grid = f(grid), None
    else:  # f, f′, f″ on the grid in one call: f's bits (the jet's), and the whole
        f_grid, *at_grid = jet.columns(grid)  # windows' bound read at their grid points
    if np.isnan(f_grid).any():
        return None
    lower, upper = grid[0], grid[-1]
    a, b = np.fmax(grid - 2 * h, lower), np.fmin(grid + 2 * h, upper)
    outer_a, outer_b = a, b
    # the largest value each window [u_k − 2h, u_k + 2h] has shown: its three grid points
    padded = np.concatenate([f_grid[:1], f_grid, f_grid[-1:]])
    seen = np.fmax(np.fmax(padded[:-2], padded[1:-1]), padded[2:])
    # the same bound on whole windows first: the screening steps only in those that pass
    # and their neighbours (a peak near a window's edge lies in its neighbour too, where
    # the bound on the whole window, read at its centre, can fall short of it)
    if _SCREEN_STEPS < _GOLDEN_STEPS:  # screening on (tests switch it off)
        if at_grid is None:
            passed = _window_bound(f, slope, curvature, a, b, seen) >= f_grid.max()
        else:  # centred on its grid point, the window reaches r either side of it
            passed = _bound(f_grid, *at_grid, np.fmax(grid - a, b - grid), seen) >= f_grid.max()
        keep = passed.copy()
        keep[1:] |= passed[:-1]
        keep[:-1] |= passed[1:]
        a, b, outer_a, outer_b, seen = a[keep], b[keep], outer_a[keep], outer_b[keep], seen[keep]
    screen = min(_SCREEN_STEPS, _GOLDEN_STEPS)
    a, b, seen, nans = _golden_steps_of_numbers(f, screen, a, b, seen)
    if nans:
        return None
    rest = _GOLDEN_STEPS - screen
    if rest:
        keep = _window_bound(f, slope, curvature, a, b, seen) >= f_grid.max()
        a, b, outer_a, outer_b, seen = a[keep], b[keep], outer_a[keep], outer_b[keep], seen[keep]
    finished = _finish_of_numbers(f, slope, curvature, rest, (a, b, seen), (outer_a, outer_b))
    if finished is None:
        return None
    values = np.concatenate([finished[0], f_grid])
    where = np.concatenate([finished[1], grid])
    if np.isnan(values).any() or np.isnan(where).any():
        return None
    top = values.max()
    return float(top), float(where[values == top].max())


def _finish_of_numbers(f, slope, curvature, steps: int, brackets: tuple, windows: tuple):
    """The last ``steps`` golden-section steps in every kept window (``brackets``: rows a,
    b, seen), then :data:`_NEWTON_STEPS` Newton steps on f′ = 0 from the brackets'
    midpoints kept inside the ``windows`` (rows of their ends): (f(u), u) rows [units of
    f, ln(rad/s)], or None where f was NaN at a golden point.

    Through :func:`_finish_function` kept with ``f`` where :meth:`Mapped.derived` gives
    it (one call instead of four, issue 15), else in numpy floats: the same IEEE
    operations on the same numbers, so the same bits."""
    a, b, seen = brackets
    outer_a, outer_b = windows
    finish = f.derived(("finish", steps), lambda fn, s, c: _finish_function(fn, s, c, steps),
                       (slope.fn, curvature.fn))
    if finish is not None and a.size:
        f_u, u, nans = finish.columns(np.stack([a, b, seen, np.zeros_like(a), outer_a, outer_b]))
        return None if np.any(nans) else (f_u, u)
    a, b, _, nans = _golden_steps_of_numbers(f, steps, a, b, seen)
    if nans:
        return None
    u = (a + b) / 2
    for _ in range(_NEWTON_STEPS):
        _, g, c = _jet_columns(f, slope, curvature, u)
        step = np.where(c < 0, -g / np.where(c < 0, c, -1.0), 0.0)
        u = np.fmin(np.fmax(u + step, outer_a), outer_b)
    return f(u), u


def _finish_function(f, slope, curvature, steps: int):
    """:func:`_finish_of_numbers`' steps as one SX Function of a window's state [a, b,
    seen, NaNs met, its ends] and ``f``'s fixed inputs → (f(u), u, NaNs met): the golden
    steps of :func:`_golden_function`, then the Newton steps of :func:`_refine_windows`
    (the same operations as the float steps)."""
    fixed = _inputs_after_first(f)
    window = ca.MX.sym("window", 6)
    a, b, seen, nans, outer_a, outer_b = ca.vertsplit(window)
    if steps:
        a, b, _, nans = ca.vertsplit(_golden_function(f, steps)(ca.vertcat(a, b, seen, nans),
                                                                *fixed))
    u = (a + b) / 2
    for _ in range(_NEWTON_STEPS):
        g, c = slope(u, *fixed), curvature(u, *fixed)
        step = ca.if_else(c < 0, -g / ca.if_else(c < 0, c, -1), 0)
        u = ca.fmin(ca.fmax(u + step, outer_a), outer_b)
    return ca.Function(f"finish_{steps}", [window, *fixed], [f(u, *fixed), u, nans]).expand()


def _golden_steps_of_numbers(f, steps: int, a, b, seen) -> tuple:
    """``steps`` golden-section steps in every window [a, b] (rows) at once: (a, b, seen,
    whether f was NaN at a point met), ``seen`` raised to the largest f met.

    Through :func:`_golden_function` kept with ``f`` (a :class:`Mapped`) where
    :meth:`Mapped.derived` gives it, else step by step in numpy floats: the same IEEE
    operations on the same numbers, so the same bits."""
    if steps == 0 or a.size == 0:
        return a, b, seen, False
    golden = f.derived(("golden", steps), lambda fn: _golden_function(fn, steps))
    if golden is not None:
        (state,) = golden.columns(np.stack([a, b, seen, np.zeros_like(a)]))
        return state[0], state[1], state[2], bool(np.any(state[3]))
    ratio = (np.sqrt(5) - 1) / 2
    for _ in range(steps):
        c = b - ratio * (b - a)
        d = a + ratio * (b - a)
        fc, fd = f(c), f(d)
        if np.isnan(fc).any() or np.isnan(fd).any():
            return a, b, seen, True
        seen = np.fmax(seen, np.fmax(fc, fd))
        left = fc > fd
        a, b = np.where(left, a, c), np.where(left, d, b)
    return a, b, seen, False


class Buffered:
    """A Function of numbers called through its evaluation buffer (``Function.buffer``:
    arguments and results in numpy arrays): ≈ 2 µs a call of one point and ≈ 10-200 µs of a
    few hundred points instead of ≈ 70-700 µs through DM conversions; the same evaluation,
    so the same bits. Each output is dense, or all structural zeros (a flat function's
    derivative), which the buffer leaves at 0. Each thread has its own buffer (a Dask
    worker with several threads runs specs that share a structure's Buffered at once)."""

    def __init__(self, fn):
        for i in range(fn.n_out()):
            if fn.nnz_out(i) not in (0, fn.numel_out(i)):
                raise ValueError(f"{fn.name()}: output {i} is neither dense nor all zeros")
        self._fn = fn
        self._buffers = ThreadBuffers([fn.numel_out(i) for i in range(fn.n_out())])

    def __call__(self, *args) -> list[np.ndarray]:
        """The Function's outputs (flat copies) at ``args`` (flat arrays of its inputs'
        sizes)."""
        _, trigger, arguments, results = self._buffers.bound(lambda: self._fn)
        for target, value in zip(arguments, args):
            target[:] = value
        trigger()
        return [r.copy() for r in results]


class Mapped:
    """A Function of one scalar, SX-expanded once, evaluated at every element of a row
    through :class:`Buffered` (one map of it per row length).

    A Function with more inputs takes them from ``fixed`` (arrays of their sizes), the
    same for every element (the map shares them); :meth:`bound` gives a view with other
    values that shares the maps. The maps are shared by threads too (a Dask worker runs
    specs in threads): each :class:`Buffered` keeps a buffer per thread. Functions derived from
    this one (:meth:`derived`: the golden-section steps, f with its derivatives) are kept
    with it and shared by the views too.
    """

    def __init__(self, fn, fixed: tuple = (), expand: bool = True):
        self.fn = _expanded(fn) if expand else fn
        self.fixed = tuple(fixed)
        self._rows: dict[int, Buffered] = {}  # row length → the map of fn over it
        # key → (what it was built from, the Mapped or the number of requests before it)
        self._derived: dict[tuple, tuple] = {}

    def bound(self, *fixed) -> "Mapped":
        """This Function with ``fixed`` for its inputs after the first (maps shared)."""
        view = object.__new__(Mapped)
        view.fn, view.fixed, view._rows = self.fn, tuple(fixed), self._rows
        view._derived = self._derived
        return view

    def _row(self, size: int) -> Buffered:
        row = self._rows.get(size)
        if row is None:  # one point: the Function itself, no map of it
            shared = [False] + [True] * (self.fn.n_in() - 1)
            row = self._rows[size] = Buffered(
                self.fn if size == 1 else self.fn.map(size, shared, [False] * self.fn.n_out()))
        return row

    def __call__(self, x) -> np.ndarray:
        x = np.atleast_1d(np.asarray(x, dtype=float))
        return self._row(x.size)(x, *self.fixed)[0]

    def columns(self, x) -> list[np.ndarray]:
        """Every output at each column of ``x`` (rows × n: a column is one value of the
        first input): each output as its rows × n, or a row of n for a scalar output."""
        x = np.asarray(x, dtype=float)
        n = x.shape[-1]
        results = self._row(n)(x.ravel(order="F"), *self.fixed)
        return [r if r.size == n else r.reshape(n, -1).T for r in results]

    def derived(self, key: tuple, build, sources: tuple = ()) -> "Mapped | None":
        """A :class:`Mapped` of ``build(self.fn, *sources)`` (a Function of the same
        inputs after the first, used as it is built), kept with this Function per ``key``
        and ``sources`` (Functions, compared by identity) and bound to this view's
        ``fixed``; None at the first :data:`DERIVED_AFTER` requests, which build nothing
        (the caller takes the float steps, the same bits).

        Building takes milliseconds, which pay back only when the same Function serves
        several loops (a structure's replayed Functions, :func:`replayed`): the first
        requests find out whether more come; a Function made for one loop sees few.
        """
        kept = self._derived.get(key)
        if kept is not None and (len(kept[0]) != len(sources) or any(
                a is not b for a, b in zip(kept[0], sources))):
            kept = None
        requests = 0 if kept is None else kept[1]
        if not isinstance(requests, Mapped):
            if requests < DERIVED_AFTER:
                self._derived[key] = (sources, requests + 1)
                return None
            kept = self._derived[key] = (sources, Mapped(build(self.fn, *sources), expand=False))
        return kept[1].bound(*self.fixed)


def _inputs_after_first(fn) -> list:
    """MX symbols for ``fn``'s inputs after the first (the fixed ones of a :class:`Mapped`)."""
    return [ca.MX.sym(f"fixed{i}", fn.sparsity_in(i)) for i in range(1, fn.n_in())]


def _golden_function(f, steps: int):
    """``steps`` golden-section steps of one window as one Function (issue 15): the state
    [a, b, seen, NaNs] of a window and ``f``'s fixed inputs → the state after them.

    Each step is :func:`_peak_of_numbers`' step (c = b − ρ(b − a), d = a + ρ(b − a),
    keep [a, d] where f(c) > f(d), else [c, b]; ``seen`` the largest f(c), f(d) met; NaNs
    counts the NaN values of f met, found as ¬(f ≥ −∞), which CasADi does not fold as
    it folds f ≠ f), the same IEEE operations on the same numbers, evaluated in CasADi
    instead of one Python round of numpy and two calls a step (≈ 100 calls a peak)."""
    ratio = (np.sqrt(5) - 1) / 2
    fixed = _inputs_after_first(f)
    state = ca.MX.sym("window", 4)
    a, b, seen, nans = ca.vertsplit(state)
    c = b - ratio * (b - a)
    d = a + ratio * (b - a)
    fc, fd = f(c, *fixed), f(d, *fixed)
    left = fc > fd
    step = ca.Function("golden_step", [state, *fixed], [ca.vertcat(
        ca.if_else(left, a, c), ca.if_else(left, d, b), ca.fmax(seen, ca.fmax(fc, fd)),
        nans + ca.logic_not(fc >= -ca.inf) + ca.logic_not(fd >= -ca.inf))])
    return _folded(step, steps, f"golden_{steps}", fixed)


def jet_function(f, slope, curvature):
    """f, f′ and f″ as one SX Function of (u, the fixed inputs), where the peaks' bounds
    and Newton steps read all three: the three graphs expanded into one with their
    common subexpressions merged (f″'s graph repeats f′'s and f's: 247 instead of
    130 + 262 + 542 instructions on a sampled loop's |T|²). Merging an operation with an
    identical one on identical operands changes no value: the same bits."""
    u = ca.MX.sym("u")
    fixed = _inputs_after_first(f)
    jet = ca.Function("jet", [u, *fixed], [g(u, *fixed) for g in (f, slope, curvature)])
    return jet.expand("jet", {"cse": True})


def _jet_columns(f, slope, curvature, u) -> list[np.ndarray]:
    """[f(u), f′(u), f″(u)] for a row ``u``, from three :class:`Mapped`: through
    :func:`jet_function` kept with ``f`` where :meth:`Mapped.derived` gives it, else
    one call of each (the same bits)."""
    jet = f.derived(("jet",), jet_function, (slope.fn, curvature.fn))
    if jet is None:
        return [f(u), slope(u), curvature(u)]
    return jet.columns(u)


#: replayed Functions kept (an LRU): (name, the function's key, derivatives, level,
#: the loop's structure) → (Mapped of f and its derivatives, Mapped of the value at ω = 0)
_REPLAY_CACHE_SIZE = 256
_replays = Lru(_REPLAY_CACHE_SIZE)


def replayed(name: str, fn, derivatives: int, level: float = 0.0, log_omega: bool = True,
             at_zero: bool = False):
    """Row evaluators of ``fn`` − ``level`` and its first ``derivatives`` derivatives for a
    loop of numbers, built once per loop structure on its parametric twin (issue 15), or
    None (``fn`` not an :class:`~feedtune.loops.twin.OfLoop`, or a loop without a twin,
    or a function that reads a number of the loop as more than arithmetic).

    ``fn`` is a function of ω [rad/s] taken in u = ln ω when ``log_omega`` (as every
    peak and crossing here), else of its own argument. Returns (evaluators, fn at ω = 0
    as a float when ``at_zero``, else None): each evaluator maps a row of u to its values
    (:class:`Mapped`, the loop's numbers bound). The Functions are those
    :func:`_functions` builds on the loop of numbers, with its numbers as a parameter
    instead of folded constants (:mod:`feedtune.loops.twin`): the same operations.
    """
    if not isinstance(fn, OfLoop):
        return None
    twin = parametric_twin(fn.loop)
    if twin is None:
        return None
    key = (name, fn.key, derivatives, level, log_omega, at_zero, twin.structure)
    built = _replays.get(key)
    if built is None:
        try:
            built = _replay_functions(name, fn, derivatives, level, log_omega, at_zero, twin)
        except (TypeError, NotImplementedError, RuntimeError, ValueError, ArithmeticError):
            built = False  # a number used as more than arithmetic: not replayed
        _replays.put(key, built)
    if built is False:
        return None
    rows, zero = built
    values = twin.values
    return ([row.bound(values) for row in rows],
            None if zero is None else float(zero(values)[0][0]))


def replayed_at(name: str, fn, x) -> float | None:
    """``fn(x)`` for a float ``x`` [fn's unit of argument], ``fn`` an
    :class:`~feedtune.loops.twin.OfLoop` of a loop of numbers, evaluated by the Function of
    ``fn`` replayed on the loop's twin (built once per structure: :func:`replayed` with
    ``log_omega`` off; issue 15), or None where there is none (``x`` an expression, a
    loop of symbols, a number that shapes the graph). The same operations as evaluating
    the graph of ``fn(x)`` built on the loop of numbers, without building it (a response
    at one ω: a complex solve, ≈ 0.3–1 ms of MX building a report). The first value of a
    (name, function, structure) is None too: building and expanding the replayed Function
    costs a few graphs, which a single tuning would pay for one value."""
    if not isinstance(x, float) or not isinstance(fn, OfLoop):
        return None
    twin = parametric_twin(fn.loop)
    if twin is None:
        return None
    if not asked_before(("at", name, fn.key, twin.structure)):  # one is cheaper as a graph
        return None
    replay = replayed(name, fn, 0, log_omega=False)
    return None if replay is None else float(replay[0][0](x)[0])


def value_at(name: str, function_of, loop, x):
    """``function_of(loop)(x)``: for a loop of numbers and a float ``x`` its number (a DM)
    by :func:`replayed_at`, else the expression (``function_of``: an
    :class:`~feedtune.loops.twin.OfLoop` factory, ``loop`` ↦ a function of ``x``)."""
    value = replayed_at(name, OfLoop(function_of, loop), x)
    return function_of(loop)(x) if value is None else ca.DM(value)


def _replay_functions(name: str, fn, derivatives: int, level: float, log_omega: bool,
                      at_zero: bool, twin):
    """(Mapped of fn − level and its u-derivatives as Functions of (u, the twin's numbers),
    Buffered of fn at ω = 0 of the numbers or None)."""
    u = ca.MX.sym("u")
    on_twin = fn.on(twin.loop)
    expressions = _with_derivatives(on_twin(ca.exp(u) if log_omega else u) - level, u,
                                    derivatives)
    if any(not (ca.is_equal(v, u) or ca.is_equal(v, twin.numbers))
           for v in ca.symvar(ca.veccat(*expressions))):
        raise ValueError("symbols besides the loop's numbers")
    rows = [Mapped(ca.Function(f"{name}_{k}", [u, twin.numbers], [e]))
            for k, e in enumerate(expressions)]
    zero = None
    if at_zero:  # fn at ω = 0 itself (u = −∞), a Function of the numbers alone
        zero = Buffered(ca.Function(f"{name}_at_zero", [twin.numbers],
                                       [ca.MX(on_twin(0.0))]).expand())
    return rows, zero


def _window_bound(f, slope, curvature, a, b, seen):
    """Upper bound on the value each window's refinement can still reach [units of f].

    After :data:`_SCREEN_STEPS` golden steps the bracket [a, b] is 5.6 % of its window
    wide (0.618⁶) and f, smooth on it, stays below f(m) + |f′(m)|·r + ½|f″|·r² there
    (m the midpoint, r = (b − a)/2). The bound doubles those rise terms (f″ is read at m
    only) above the largest value the window has shown (its grid points, its golden
    points and f(m): the Newton steps start from the bracket and stay inside the window,
    whose ends are within rounding of its grid points), and adds 1e-12 of the largest |f|
    seen for the rounding of f (≈ 1e-16 relative, 1e-12 leaves a condition number of
    10⁴): a window whose refinement could reach the top is never dropped.
    """
    m, r = (a + b) / 2, (b - a) / 2
    return _bound(*_jet_columns(f, slope, curvature, m), r, seen)


def _bound(f_m, slope_m, curvature_m, r, seen):
    """:func:`_window_bound` from f, f′, f″ at the windows' centres m and the distance r
    [ln(rad/s)] each window reaches from its centre: max(seen, f(m)) + 2(|f′(m)|·r +
    ½|f″(m)|·r²) + 1e-12·max|seen| [units of f]. The screen of whole windows reads it at
    their grid points (f, f′, f″ there from the jet that gives the grid's values, issue 15),
    r the larger side of a window clipped at the band's end (2h inside)."""
    rise = 2 * (np.abs(slope_m) * r + 0.5 * np.abs(curvature_m) * r**2)
    return np.fmax(seen, f_m) + rise + 1e-12 * np.max(np.abs(seen))


def lowest_value(fn, band: tuple, count: int, name: str = "lowest"):
    """(min of ``fn`` over ω in ``band``, the ω [rad/s] where it is taken).

    Every window of a grid of ``count`` points is refined (golden section, Newton) and the
    smallest value wins. The band's ends may be expressions that move with the NLP's
    variables (a bandwidth candidate b).
    """
    lo, hi = band
    u_lo, u_hi = ca.log(lo), ca.log(hi)
    centres = u_lo + ca.DM(np.linspace(0.0, 1.0, count)).T * (u_hi - u_lo)
    h = (u_hi - u_lo) / (count - 1) / 2
    (f, slope, curvature), free = _functions(name, lambda w: -fn(w), 2)
    values, u = _refine_windows(f, slope, curvature, free, centres, h, u_lo, u_hi)
    top, u = _best(ca.horzcat(values, f.map(count)(centres, *free)), ca.horzcat(u, centres))
    return -top, ca.exp(u)


def _relative_points(ratio: float) -> int:
    return int(np.ceil(np.log10(ratio) * POINTS_PER_DECADE)) + 1


def relative_grid(band: tuple[float, float]) -> np.ndarray:
    """Points x in (0, 1) so that b·x covers [band low, b) logarithmically; read-only,
    computed once per band (``np.geomspace`` ≈ 50 µs, once a tuned design's bandwidth
    before; issue 15)."""
    return _relative_grid(float(band[0]), float(band[1]))


@functools.lru_cache(maxsize=256)
def _relative_grid(lo: float, hi: float) -> np.ndarray:
    grid = np.geomspace(lo / hi, 1.0, _relative_points(hi / lo))[:-1]
    grid.flags.writeable = False
    return grid
