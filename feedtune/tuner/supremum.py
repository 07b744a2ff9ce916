"""Peaks and crossings over frequency as semi-infinite constraints, by the exchange method.

A :class:`~feedtune.expr.Supremum` bound fn(ω) ≤ c is held on a coarse grid (every
ROW_STRIDE-th point of the metric's grid), each point written in a bounded form
((f − c)/(f + c) ≤ 0), so no row blows up where a closed-loop pole crosses the jω axis. A
:class:`~feedtune.expr.Crossing` becomes an auxiliary variable b with
condition(b·x) ≥ DIP_MARGIN·(1 − x) on a coarse relative grid x ∈ (0, 1). The rows are
one CasADi Function of ω mapped over the grid, not a Python loop of expressions.

After each solve the refined peak (or dip) is evaluated numerically (:class:`FrequencyScan`:
the metric's full grid, every window refined by golden section, all windows at once on
the SX-expanded function); while it violates its bound, its frequency is switched on as
one more constraint row (a parameter ``slot`` of the built NLP whose row bounds are open
until then) and IPOPT runs again from the last solution. Putting the refined peak itself
in the NLP was tried and stalled IPOPT: its value switches between peaks, so its
derivatives jump.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from feedtune.expr import Crossing, PoleRegion, Supremum
from feedtune.loops.frequency import Buffered
from feedtune.tuner.builder import NlpBuilder
from feedtune.tuner.poles import PoleScan

#: frequencies the exchange method may add to one peak or crossing, per start. Every slot is
#: a row of the NLP whether switched on or not, and a tracked row (:func:`tracked`) is dear:
#: with 16 slots per group the 32 exchange rows were 57 % of the Jacobian's 520k SX
#: instructions on Bhatia's spec (1.0 of 2.1 ms a call; 50 % on Ward-Leonard's), before
#: their slope and curvature were differences (the user drive's 30: 55 % → 25 %). Measured
#: (2026-11-27, bhatia_speed.py's 26 tunings): at most 7 points a start on Bhatia's spec and
#: variants, 15 (both groups) on Ward-Leonard variant 01; with 10 every tuning reaches what
#: it reached with 16, in fewer iterations on 13 of them (Ward-Leonard's bundled spec 271 →
#: 166 to the same 25.5627 rad/s); 6 or 8 sent the bundled Ward-Leonard spec to its other
#: local optimum (25.5571 rad/s), 4 ran out on five Bhatia variants
EXCHANGE_POINTS = 10
#: NLP rows on every ROW_STRIDE-th point of a metric's frequency grid (40 per decade): the
#: exchange method adds the points that matter, so the NLP stays small
ROW_STRIDE = 2
#: a refined peak above its bound (relative), or a dip below a crossing condition's zero
#: (the condition is bounded, so absolute), by more than this adds its frequency
EXCHANGE_TOL = 1e-7
#: a crossing's condition must exceed DIP_MARGIN·(1 − x) at ω = b·x below b: without it the
#: optimiser parks a dip exactly on the level (a tangency) and claims the crossing beyond
#: it, where any rounding puts the first crossing at the dip (measured on Bhatia's showcase:
#: 690 rad/s claimed, 471 rad/s by python-control)
DIP_MARGIN = 1e-3
#: golden-section steps in each window of two grid steps: the bracket shrinks to 1e-10
GOLDEN_STEPS = 48
#: half-width h of the central differences in ln ω that give a tracked exchange row its
#: slope and curvature (:func:`tracked`). Truncation: the Newton step's relative error is
#: ≈ (h/w)²/12 at a peak of half-width w in ln ω (w ≈ ζ at a resonance of damping ζ:
#: 2e-6 at ζ = 0.02, the user drive's mode); rounding: ≈ 4ε/h² = 1e-7 on the curvature
#: of a row bounded by 1 (the bounded forms above), against curvatures of order 1/w²
CURVATURE_STEP = 1e-4
_GOLDEN = (math.sqrt(5) - 1) / 2


class FrequencyFunction:
    """f(ω) of the NLP's symbols, ω [rad/s]: rows for the NLP, numbers for the checks.

    ``fn(omega)`` is the metric's callable; ``z`` and ``p`` the builder's log tunables and
    the parameters existing when it is made (a numeric call passes that many).

    The NLP's rows: the split's ``point`` (below) replayed on a whole row of ω
    (:func:`whole_rows`), so the loop's polynomial coefficients are computed once for all
    frequencies, not once per frequency as a Function mapped over ω would (measured on
    Bhatia's loop: 141 SX instructions per frequency mapped, the Hessian of 258 rows 725k
    instructions), and an unexpanded NLP holds one vector node per instruction of
    ``point``. Without an SX form ``fn`` is called on the row; a callable that does not
    work elementwise on a row falls back to the mapped Function.

    The numeric checks (the exchange method's scans, the starts' peaks and crossings): where
    ``fn`` expands to SX, it is split once (``casadi.extract_parametric``) into the numbers
    that depend on the tunables and parameters only, ``q(z, p)`` (the loop's coefficients),
    and ``point(ω, q, z, p)``, one frequency's value from them (z and p read only where they
    stand bare, a plant number beside ω); a call computes ``q`` once for its
    z and p and maps ``point`` over its frequencies through CasADi's evaluation buffer, with
    no graph built per row length. Measured on ``examples/user-defined-pid-notch.json``: a
    call of 1-512 frequencies 100-750 µs → 12-230 µs, the exchange checks of a cold tuning
    0.18 → 0.06 s CPU. (Mapping ``point`` inside the NLP too, as a call kept through the
    expansion, built the solver in 0.08 instead of 0.41 s but made its constraint Jacobian
    2.5× dearer to evaluate: 5.2 against 2.1 ms a call, 60 calls a tuning; not kept.)
    """

    def __init__(self, name: str, fn, z: ca.MX, p: ca.MX):
        self.name, self.fn = name, fn
        self.z, self.p, self.n_params = z, p, p.numel()
        self._symbolic: dict[int, ca.Function] = {}
        self._numeric: dict[int, ca.Function | Buffered] = {}  # row length → its evaluation
        self._split: tuple[ca.Function, ca.Function] | None | bool = False  # not tried yet
        self._is_elementwise: bool | None = None
        self._numbers_call: Buffered | None = None
        self._last_numbers: tuple[bytes, np.ndarray] | None = None  # (z and p, q)

    def split(self) -> tuple[ca.Function, ca.Function] | None:
        """(point(ω, q, z, p), q(z, p)) as SX Functions, or None where ``fn`` has no SX
        form. ``q`` holds every sub-expression of z and p alone; ``point`` reads z and p
        only where they stand bare (a plant number beside ω)."""
        if self._split is False:
            self._split = None
            omega = ca.MX.sym("omega")
            try:
                whole = ca.Function(self.name, [omega, self.z, self.p], [self.fn(omega)]).expand()
            except RuntimeError:  # a node without an SX form
                return None
            w = ca.SX.sym("omega")
            z, p = ca.SX.sym("z", self.z.sparsity()), ca.SX.sym("p", self.p.sparsity())
            value, symbols, parametric = ca.extract_parametric(whole(w, z, p), ca.veccat(z, p))
            q = ca.veccat(*symbols) if symbols else ca.SX(0, 1)
            self._split = (  # z and p stay inputs of point: a bare symbol is not extracted
                ca.Function(f"{self.name}_point", [w, q, z, p], [value]),
                ca.Function(f"{self.name}_numbers", [z, p],
                            [ca.veccat(*parametric) if parametric else ca.SX(0, 1)]))
        return self._split

    def function(self, n: int) -> ca.Function:
        """(ω row 1×n, z, p) ↦ f row 1×n, built once per n: ``point`` replayed on whole
        rows (:func:`whole_rows`) where ``fn`` has an SX form, else ``fn`` called on the
        row (or mapped, where it does not work elementwise)."""
        built = self._symbolic.get(n)
        if built is None:
            omega = ca.MX.sym("omega", 1, n)
            split = self.split() if self._elementwise() else None
            if split is not None:
                point, numbers = split
                q = ca.MX.sym("q", point.sparsity_in(1))
                try:
                    rows = ca.Function(f"{self.name}_rows{n}", [omega, q, self.z, self.p],
                                       [whole_rows(point, [omega, q, self.z, self.p])])
                except ValueError:  # an instruction not replayed (a call): fn on the row
                    split = None
                else:
                    built = ca.Function(self.name, [omega, self.z, self.p],
                                        [rows(omega, numbers(self.z, self.p), self.z, self.p)])
            if split is None:
                try:
                    value = self.fn(omega)
                    if value.shape != (1, n):
                        raise ValueError(f"{self.name}: fn gives {value.shape}, not (1, {n})")
                    built = ca.Function(self.name, [omega, self.z, self.p], [value])
                except (RuntimeError, ValueError):  # not elementwise: one ω at a time
                    scalar = ca.MX.sym("omega")
                    built = ca.Function(self.name, [scalar, self.z, self.p],
                                        [self.fn(scalar)]).map(n)
            self._symbolic[n] = built
        return built

    def _elementwise(self) -> bool:
        """Whether ``fn`` on a row of two frequencies gives a row of two values (tried once:
        what is not, such as w·wᵀ, is mapped one ω at a time)."""
        if self._is_elementwise is None:
            try:
                self._is_elementwise = self.fn(ca.MX.sym("omega", 1, 2)).shape == (1, 2)
            except RuntimeError:
                self._is_elementwise = False
        return self._is_elementwise

    def rows(self, omegas):
        """f at every entry of the row ``omegas`` (an expression or numbers): a 1×n row of
        expressions of the NLP's symbols."""
        return self.function(omegas.shape[1])(omegas, self.z, self.p)

    def __call__(self, omegas: np.ndarray, z: np.ndarray, p: np.ndarray) -> np.ndarray:
        """f [its unit] at the numbers ``omegas`` [rad/s], tunables ``z``, parameters ``p``
        (calls are padded to a power of two so that few sizes are built)."""
        omegas = np.atleast_1d(np.asarray(omegas, dtype=float))
        n = 1 << max(0, int(omegas.size - 1).bit_length())
        padded = np.concatenate([omegas, np.full(n - omegas.size, omegas[-1])])
        split = self.split()
        if split is not None:
            z = np.asarray(z, dtype=float).ravel()
            p = np.asarray(p, dtype=float).ravel()[:self.n_params]
            return self._points(n, split)(padded, self._numbers(z, p, split), z, p)[0][
                :omegas.size]
        numeric = self._numeric.get(n)
        if numeric is None:
            numeric = self.function(n)
            try:
                numeric = numeric.expand()
            except RuntimeError:  # a node without an SX form
                pass
            self._numeric[n] = numeric
        value = numeric(padded[None, :], z, p[:self.n_params])
        return np.asarray(value, dtype=float).ravel()[:omegas.size]

    def _numbers(self, z: np.ndarray, p: np.ndarray, split) -> np.ndarray:
        """q(z, p), computed once for consecutive calls at the same z and p (a scan's
        golden-section steps)."""
        key = z.tobytes() + p.tobytes()
        if self._last_numbers is None or self._last_numbers[0] != key:
            if self._numbers_call is None:
                self._numbers_call = Buffered(split[1])
            self._last_numbers = (key, self._numbers_call(z, p)[0])
        return self._last_numbers[1]

    def _points(self, n: int, split) -> "Buffered":
        """point mapped over a row of n frequencies, evaluated through CasADi's buffer."""
        points = self._numeric.get(n)
        if points is None:
            point = split[0]
            omega = ca.MX.sym("omega", 1, n)
            q, z, p = (ca.MX.sym(name, point.sparsity_in(i))
                       for i, name in ((1, "q"), (2, "z"), (3, "p")))
            points = self._numeric[n] = Buffered(ca.Function(
                f"{self.name}_row{n}", [omega, q, z, p], [point.map(n)(omega, q, z, p)]))
        return points


def whole_rows(point: ca.Function, args: list[ca.MX]) -> ca.MX:
    """``point`` (an SX Function of one frequency ω, its first input) on the 1×n row of
    frequencies ``args[0]``: its instructions replayed as MX operations, each on the whole
    row where it depends on ω and on a scalar where it does not (the other inputs' entries).

    The rows of one grid are then about as many MX nodes as ``point`` has instructions
    (≈ 65 for the user drive's |T|²), each a vector operation, and the NLP's unexpanded
    Jacobian differentiates those nodes instead of every grid point's scalar operations
    (see feedtune.tuner.nlp.WHOLE_ROWS_NODES_PER_ROW). The same operations in the same order
    as the SX expansion of ``fn`` on a row, so the same values. ValueError for an
    instruction that is not a unary or binary operation (a call).
    """
    work: dict[int, ca.MX] = {}
    value = None
    for k in range(point.n_instructions()):
        op, inputs = point.instruction_id(k), point.instruction_input(k)
        out = point.instruction_output(k)
        if op == ca.OP_INPUT:
            given = args[inputs[0]]
            work[out[0]] = given if inputs[0] == 0 else given[inputs[1]]
        elif op == ca.OP_OUTPUT:
            value = work[inputs[0]]
        elif op == ca.OP_CONST:
            work[out[0]] = ca.MX(point.instruction_constant(k))
        elif op == ca.OP_CALL or len(inputs) > 2:
            raise ValueError(f"{point.name()}: instruction {k} (operation {op}) is not replayed")
        elif len(inputs) == 1:
            work[out[0]] = ca.MX.unary(op, work[inputs[0]])
        else:
            work[out[0]] = ca.MX.binary(op, work[inputs[0]], work[inputs[1]])
    n = args[0].shape[1]
    return value if value.shape == (1, n) else ca.repmat(value, 1, n)


def window_maxima(f, centres: np.ndarray, h: float | np.ndarray, lower: float,
                  upper: float) -> tuple[np.ndarray, np.ndarray]:
    """Maximum of f(u) in every window [c − 2h, c + 2h] ∩ [lower, upper], all at once.

    Golden section in every window together (one call of ``f`` on an array per step), as
    feedtune.loops.frequency refines peaks symbolically. Returns (values, u).
    """
    a = np.maximum(centres - 2 * h, lower)
    b = np.minimum(centres + 2 * h, upper)
    n = len(centres)
    for _ in range(GOLDEN_STEPS):
        c = b - _GOLDEN * (b - a)
        d = a + _GOLDEN * (b - a)
        values = f(np.concatenate([c, d]))
        left = values[:n] > values[n:]
        a, b = np.where(left, a, c), np.where(left, d, b)
    u = (a + b) / 2
    return f(u), u


def _top(values: np.ndarray, u: np.ndarray) -> tuple[float, float]:
    """(largest of the finite values, its u); (−inf, nan) when none is finite."""
    values = np.where(np.isfinite(values), values, -np.inf)
    k = int(np.argmax(values))
    return (float(values[k]), float(u[k])) if np.isfinite(values[k]) else (-math.inf, math.nan)


def refined_maxima(f, u: np.ndarray, lower: float,
                   upper: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Local maxima of f over [lower, upper] from its values on the even grid ``u``: every
    grid point that is a local maximum (ends included) refined in its window of two grid
    steps (:func:`window_maxima`). Returns (refined values, their u, f on the grid)."""
    values = f(u)
    finite = np.where(np.isfinite(values), values, -np.inf)
    left = np.concatenate([[-np.inf], finite[:-1]])
    right = np.concatenate([finite[1:], [-np.inf]])
    candidates = np.flatnonzero((finite >= left) & (finite >= right) & np.isfinite(finite))
    if candidates.size == 0:
        return np.zeros(0), np.zeros(0), finite
    refined, where = window_maxima(f, u[candidates], (u[1] - u[0]) / 2, lower, upper)
    return refined, where, finite


def refined_maximum(f, u: np.ndarray, lower: float, upper: float) -> tuple[float, float]:
    """(max of f over [lower, upper], its u): the largest of :func:`refined_maxima` and
    the grid values; (−inf, nan) when no value is finite."""
    refined, where, finite = refined_maxima(f, u, lower, upper)
    return _top(np.concatenate([refined, finite]), np.concatenate([where, u]))


def _worst_first(amounts: np.ndarray, places: np.ndarray) -> list[tuple[float, float]]:
    """(amount, place) pairs, largest amount first, one per place (relative 1e-9 apart)."""
    pairs = []
    for k in np.argsort(-amounts, kind="stable"):
        if all(abs(places[k] - q) > 1e-9 * abs(q) for _, q in pairs):
            pairs.append((float(amounts[k]), float(places[k])))
    return pairs


class SupremumScan:
    """The refined maximum of a Supremum's fn over its grid (and ω = 0), numerically."""

    def __init__(self, name: str, value: Supremum, z, p):
        self.fn = FrequencyFunction(name, value.fn, z, p)
        self.u = np.log(np.asarray(value.grid, dtype=float))

    def peak(self, z, p) -> tuple[float, float]:
        """(max over ω of fn, the ω [rad/s] where it is taken; 0 for ω → 0)."""
        top, at = refined_maximum(lambda u: self.fn(np.exp(u), z, p), self.u, self.u[0],
                                  self.u[-1])
        at_zero = float(self.fn(np.zeros(1), z, p)[0])
        if at_zero >= top:
            return at_zero, 0.0
        return top, math.exp(at)

    def exact(self, z, p) -> float:
        """The Supremum's value: its refined peak."""
        return self.peak(z, p)[0]

    def local_peaks(self, z, p) -> tuple[np.ndarray, np.ndarray]:
        """(every refined local peak of fn, its ω [rad/s])."""
        refined, where, _ = refined_maxima(lambda u: self.fn(np.exp(u), z, p), self.u,
                                           self.u[0], self.u[-1])
        return refined, np.exp(where)


class CrossingScan:
    """A Crossing's first ω where its condition falls to 0, and its dips, numerically."""

    def __init__(self, name: str, value: Crossing, z, p):
        self.fn = FrequencyFunction(name, value.condition, z, p)
        self.band = value.band
        self.count = len(value.relative_grid) + 1  # the metric's grid over its band

    def crossing(self, z, p) -> float:
        """Lowest ω [rad/s] in the band where the condition falls below 0 (the band's top
        when it does not), by the grid and then Brent's method in ln ω."""
        from scipy.optimize import brentq

        u = np.linspace(math.log(self.band[0]), math.log(self.band[1]), self.count)
        below = np.flatnonzero(~(self.fn(np.exp(u), z, p) > 0))
        if below.size == 0:
            return float(self.band[1])
        k = int(below[0])
        if k == 0:
            return float(self.band[0])
        return math.exp(brentq(lambda v: float(self.fn(np.exp([v]), z, p)[0]), u[k - 1], u[k],
                               xtol=1e-14, rtol=4 * np.finfo(float).eps))

    def exact(self, z, p) -> float:
        """The Crossing's value [rad/s]: its first crossing."""
        return self.crossing(z, p)

    def local_dips(self, z, p, b: float, margin: float) -> tuple[np.ndarray, np.ndarray]:
        """(every refined local minimum over ω ≤ b of condition(ω) − margin·(1 − ω/b), its
        ω [rad/s])."""
        lo, hi = math.log(self.band[0]), math.log(b)

        def f(u):
            omega = np.exp(u)
            return -(self.fn(omega, z, p) - margin * (1 - omega / b))

        refined, where, _ = refined_maxima(f, np.linspace(lo, hi, self.count), lo, hi)
        return -refined, np.exp(where)


def make_scan(name: str, value, z, p) -> SupremumScan | CrossingScan | PoleScan | None:
    """The numeric scan of a Supremum, Crossing or PoleRegion (None for any other metric
    value)."""
    if isinstance(value, PoleRegion):
        return PoleScan(name, value, z, p)
    if isinstance(value, Supremum):
        return SupremumScan(name, value, z, p)
    if isinstance(value, Crossing):
        return CrossingScan(name, value, z, p)
    return None


@dataclass
class ExchangeGroup:
    """The exchange rows of one peak or crossing.

    ``bounds`` are the rows' bounds once switched on; ``slots`` and ``rows`` the indices of
    each point's parameter and constraint row; ``scan`` evaluates the refined peak or dip;
    ``level`` is the expression the check needs besides the tunables (the peak's bound, or
    the crossing variable b [rad/s]).
    """

    scan: SupremumScan | CrossingScan
    level: object
    bounds: tuple[float, float]
    slots: list[int] = field(default_factory=list)
    rows: range = range(0)

    def violations(self, z, p, level: float) -> list[tuple[float, float]]:
        """Every refined local peak's excess over ``level`` relative to it [1] (or every
        local dip's fall below 0 under b = ``level`` [1]), worst first, each with the slot
        value that holds it: ω [rad/s] for a peak, x = ω/b for a crossing."""
        if isinstance(self.scan, SupremumScan):
            peaks, where = self.scan.local_peaks(z, p)
            return _worst_first((peaks - level) / (abs(level) + 1e-300), where)
        dips, where = self.scan.local_dips(z, p, level, DIP_MARGIN)
        return _worst_first(-dips, where / level)


def tracked(row_at, slots: ca.MX, step: float, maximum: bool) -> ca.MX:
    """``row_at`` at each slot value moved by one Newton step towards its local maximum
    (``maximum``) or minimum, in ln(slot), by at most ``step`` (a grid step of ln ω).

    A row at a fixed frequency holds a peak only where the peak was when the point was
    added; the peak then moves with the tunables and the next check finds it above its
    bound beside the point (measured on Ward-Leonard variant 01: 25 points added, 2e-3
    to 4e-2 relative excess each round, until none was left). At the moved point the row
    follows its local extremum to second order: δ = r_u / max(∓r_uu, |r_u|/step) (u = ln
    slot), so |δ| ≤ step, and δ = 0 at a point where the extremum is (where the exchange
    check puts it). Where the row is flatter than 2·EXCHANGE_TOL/step² (curving by less
    than the check's tolerance over one step), that curvature stands in for −r_uu: the
    differences there are rounding noise (an exact 0 where the row is flat to the last
    bit, e.g. |T| = 1 at low ω), and a 1e-300 floor made the row's Jacobian 1e256.
    ``row_at`` maps a 1×n row of slot values to a 1×n row of expressions, each entry
    depending on its own slot only.

    r_u and r_uu are central differences of the row at u ± :data:`CURVATURE_STEP` (the
    Newton step of the parabola through three points; see there for its accuracy), not
    derivatives of the row's graph: differentiated in u twice and then by IPOPT's
    Jacobian in the tunables, the row's graph grew ninefold (third derivatives; measured
    on ``examples/user-defined-pid-notch.json``: the 30 tracked rows 27.6k of the NLP's
    52.8k SX instructions and 243k of its Jacobian's 442k, now 7.8k and 68k).

    The row is evaluated twice, each time on all slots at once (at the three points of
    every slot, then at the moved slots), so what does not depend on ω (a loop's
    polynomial coefficients) is computed twice for all slots, not once per slot: mapping
    a one-slot Function over the slots computed the coefficients again in every slot once
    expanded (measured on the bundled Ward-Leonard spec: 32 rows, 26k of the NLP's 65k SX
    instructions).
    """
    n = slots.numel()
    sign = 1.0 if maximum else -1.0
    u, h = ca.log(slots), CURVATURE_STEP
    around = sign * row_at(ca.exp(ca.horzcat(u - h, u, u + h)))
    below, at, above = around[:, :n], around[:, n:2 * n], around[:, 2 * n:]
    r_u = (above - below) / (2 * h)
    r_uu = (above - 2 * at + below) / h**2
    delta = r_u / ca.fmax(ca.fmax(-r_uu, ca.fabs(r_u) / step), 2 * EXCHANGE_TOL / step**2)
    return row_at(ca.exp(u + delta))


def _exchange_rows(builder: NlpBuilder, group: ExchangeGroup, default: float, constraint_at,
                   step: float, maximum: bool):
    """EXCHANGE_POINTS rows ``constraint_at(slots)`` (each tracking its local maximum or
    minimum, :func:`tracked`), off until the check switches them on."""
    symbols = []
    for _ in range(EXCHANGE_POINTS):
        index, symbol = builder.slot(f"exchange{len(builder.slots)}", default)
        group.slots.append(index)
        symbols.append(symbol)
    rows = tracked(constraint_at, ca.horzcat(*symbols), step, maximum)
    group.rows = builder.constrain_all(rows, -ca.inf, ca.inf)
    return group


def crossing_variable(builder: NlpBuilder, value: Crossing, scan: "CrossingScan", index,
                      equality: bool, groups: list[ExchangeGroup]):
    """b = exp(u) [rad/s], the crossing of ``value`` as an NLP variable.

    condition(b·x) ≥ DIP_MARGIN·(1 − x) on the coarse relative grid and at exchange points;
    condition(b) = 0 when b must be the crossing itself (``equality``), ≥ 0 when it is
    maximised or bounded below. Appends its exchange group to ``groups``.
    """
    lo, hi = value.band
    u = builder.variable(f"log_crossing{index}", math.log(lo), math.log(hi), ca.log, scan)
    b = ca.exp(u)
    builder.constrain(scan.fn.rows(b), 0, 0 if equality else ca.inf)

    def rows(x):
        return scan.fn.rows(b * x) - DIP_MARGIN * (1 - x)

    grid = np.asarray(value.relative_grid, dtype=float)[::ROW_STRIDE]
    builder.constrain_all(rows(ca.DM(grid).T), 0, ca.inf)
    step = float(np.min(np.diff(np.log(np.asarray(value.relative_grid, dtype=float)))))
    groups.append(_exchange_rows(builder, ExchangeGroup(scan, b, (0, ca.inf)), float(grid[0]),
                                 rows, step, maximum=False))
    return b


def supremum_below(builder: NlpBuilder, value: Supremum, scan: "SupremumScan", bound, s,
                   positive: bool, groups: list[ExchangeGroup]) -> None:
    """value.fn(ω) ≤ ``bound`` on the coarse grid and at exchange points, written
    (fn − bound)/(fn + bound) ≤ 0 when the bound is positive (bounded in [−1, 1]), else
    (fn − bound)/s. Appends its exchange group to ``groups``."""
    def rows(omegas):
        v = scan.fn.rows(omegas)
        return (v - bound) / (v + bound) if positive else (v - bound) / s

    grid = np.asarray(value.grid, dtype=float)[::ROW_STRIDE]
    builder.constrain_all(rows(ca.DM(grid).T), -ca.inf, 0)
    step = float(np.min(np.diff(scan.u)))
    groups.append(_exchange_rows(builder, ExchangeGroup(scan, bound, (-ca.inf, 0)),
                                 float(grid[0]), rows, step, maximum=True))


def add_exchange_points(groups: list[ExchangeGroup],
                        violations: list[list[tuple[float, float]]], slots: np.ndarray,
                        lbg: np.ndarray, ubg: np.ndarray, used: list[int]) -> bool | None:
    """Switch on a row at every violated refined peak/dip of every group (in place).

    ``violations`` holds each group's (violation, slot value) pairs at the last solution,
    worst first (:meth:`ExchangeGroup.violations`): every violated local peak gets a point
    in the same round, so one IPOPT round serves several resonances. ``used`` counts each
    group's rows already on. True when points were added, False when nothing is violated,
    None when a group's worst violation finds no point left.
    """
    added = False
    for number, (group, pairs) in enumerate(zip(groups, violations)):
        for rank, (amount, at) in enumerate(pairs):
            if not (amount > EXCHANGE_TOL and math.isfinite(at) and at > 0):
                continue
            if used[number] == len(group.slots):
                if rank == 0:
                    return None
                break
            slots[group.slots[used[number]]] = at
            row = group.rows[used[number]]
            lbg[row], ubg[row] = group.bounds
            used[number] += 1
            added = True
    return added
