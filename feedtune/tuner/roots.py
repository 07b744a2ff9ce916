"""One free tunable and one |e| minimised: each start solved by a root of the signed e.

A problem whose only free tunable is z = ln x and whose objective is one magnitude |e(z)|
(weight > 0) becomes, in the NLP, an epigraph: minimise t subject to −t ≤ e(z) ≤ t, so
IPOPT solves a two-variable problem for what is a root of e in the feasible set. Here
(measured in benchmarks/README.md, branches h-bst5 and h-bst6: the same optimum to within
IPOPT's own spread between starts, a quarter of IPOPT's CPU or less)

1. the signed e and the feasibility of every grid point are evaluated once per problem:
   the starts, the box's ends and :data:`GRID_POINTS` points evenly spaced in z, in one
   call of the NLP check's Function mapped over them (the expressions IPOPT sees, not
   expanded);
2. a start whose grid point is feasible goes downhill on |e| (the side where |e| falls
   over :data:`SLOPE_STEP`, as IPOPT's first step), from grid point to grid point of its
   feasible run, to the first sign change of e: its root is found by
   ``scipy.optimize.brentq`` to :data:`ROOT_XTOL` in z, where |e| is 0 to rounding, the
   global minimum of |e|. A bracket two starts reach is searched once;
3. reaching the run's end without a sign change, the optimum is that end when |e| is
   least there and rises into the run over :data:`EDGE_STEP` (the first-order condition
   of a vertex): a bound of the box, or a constraint's crossing, the root of the violated
   bound row found by brentq and kept on the feasible side;
4. a start whose grid point is infeasible enters the feasible run nearest it at that run's
   crossing (IPOPT's restoration phase: the nearest feasible point) and goes on downhill
   from there, or ends there when |e| rises inward and the run has no sign change.

Everything else is declined and that start is solved by IPOPT, so every start's evidence
stays its own and a result says per start which method solved it: an interior minimum of
|e| without a root; a boundary made by a stability or settling condition (which the NLP
holds with a margin); a crossing that is a local minimum of |e| while its run has a root
(IPOPT from such starts went either way, to the crossing or over it to the root: measured
on the batch's 200 such specs); a root or end point that the NLP check finds infeasible.

With several free tunables (:func:`applies_along`) the search runs along one tunable, the
others held at a point (:meth:`RootSearch.for_problem`'s ``held``, its grid that point's
alone): feedtune.tuner.nlp uses it for the starts after one that reached |e| = 0 (which no
later start can beat), one tunable at a time; only a root counts there (a line's bound or
crossing is no optimum of the whole problem), and such a start's end point lies on the
curve of e = 0, not where IPOPT's barrier would have led it (both are optima: the result
says the optimum is not unique). Measured on the batch's 100 two-tunable specs
(benchmarks/README.md, h-bipo): 197 of the 267 later starts of the 89 specs that reach
e = 0 solved so, |e| ≤ 2.2e-16 m (IPOPT from the same starts: ≤ 8.7e-13 m), the
tuned point IPOPT's bits.

The search sees only numbers from a callable (duck-typed, no plant or metric name):
``evaluate(z) -> (e, bound rows, other)`` with e the signed error, the bound rows' signed
relative violations (≤ 0 where each holds) and the largest violation of every other
condition (stability, settling; ≤ 0 where they hold, +inf where undefined).
"""

from __future__ import annotations

import math
import threading
import weakref
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

# a boundary's bisection width and the step into a run from its end [1] in z: the scalar
# search's (a relative 1e-10 and 1e-8 of the tunable)
from feedtune.tuner.scalar import BOUNDARY_XTOL, EDGE_STEP

#: points evenly spaced in z over the box, besides the starts and the box's ends: h-bst5
#: measured 17 (benchmarks/README.md): with the starts and ends alone the scalar search
#: missed a sign change on 11 of 40 specs, with 17 more none of the 60
GRID_POINTS = 17
#: brentq's tolerance [1] in z = ln x: a relative 1e-14 of the tunable, below IPOPT's own
#: spread of ln x between starts reaching one optimum (median 3e-12, 90 % 3e-10,
#: benchmarks/README.md, h-bst5) and above rounding of z ≈ 5 (≈ 1e-15)
ROOT_XTOL = 1e-14
#: step [1] in z from a start that decides which way is downhill (a relative 1e-6 of the
#: tunable: |e| changes over it by |e'|·1e-6, far above its rounding)
SLOPE_STEP = 1e-6


def applies(problem) -> bool:
    """One free tunable, no exchange point, no numeric scan, and an objective of one
    magnitude term minimised (weight > 0): the NLP's epigraph of |e|."""
    return problem.has_nlp and problem.n_z == 1 and _one_magnitude(problem)


def applies_along(problem) -> bool:
    """As :func:`applies`, with more than one free tunable: a search along one of them, the
    others held (:meth:`RootSearch.for_problem`)."""
    return problem.has_nlp and problem.n_z > 1 and _one_magnitude(problem)


def _one_magnitude(problem) -> bool:
    """No exchange point, no numeric scan, and an objective of one magnitude term
    minimised (weight > 0)."""
    ev = problem.evaluator
    return bool(not problem.exchange_groups and ev.term_magnitude == [True]
                and len(ev.weights) == 1 and ev.weights[0] > 0
                and ev.term_scans == [None] and all(s is None for s in ev.bound_scans))


@dataclass
class Found:
    """A start solved: its end point z [ln tunable], the error evaluations its search took
    beyond the shared grid (a root an earlier start found is not searched again, and its
    evaluations count for both) [count], and whether it lies on a bound or a constraint's crossing."""

    z: float
    evaluations: int
    vertex: bool


@dataclass
class RootSearch:
    """Grid and roots on a problem with one free tunable and one |e| (module docstring)."""

    evaluate: Callable
    lower: float
    upper: float
    starts: np.ndarray
    grid_points: int = GRID_POINTS
    evaluate_all: Callable | None = None  # points at an array of z, as [evaluate(z), ...]
    grid: np.ndarray = field(init=False)
    errors: np.ndarray = field(init=False)  # the signed e at each grid point
    feasible: np.ndarray = field(init=False)
    evaluations: int = field(init=False, default=0)  # of the error, by every start
    _charged: int = field(init=False, default=0)  # by the start being solved
    _roots: dict = field(init=False, default_factory=dict)  # bracket → (root, evaluations)
    _points: dict = field(init=False, default_factory=dict)  # z → its point (:meth:`_at`)

    def __post_init__(self):
        self.grid = np.unique(np.concatenate([
            [self.lower, self.upper], np.clip(self.starts, self.lower, self.upper),
            np.linspace(self.lower, self.upper, self.grid_points)]))
        points = (self.evaluate_all(self.grid) if self.evaluate_all is not None else
                  [self.evaluate(z) for z in self.grid])
        self.evaluations = len(self.grid)
        self.errors = np.array([p[0] for p in points], dtype=float)
        self.feasible = np.array([_feasible(p) for p in points])
        self._points = {_key(z): p for z, p in zip(self.grid.tolist(), points)}

    @classmethod
    def for_problem(cls, problem, held: np.ndarray | None = None, axis: int = 0,
                    check: "ErrorCheck | None" = None) -> "RootSearch | None":
        """The search on ``problem``'s NLP check Function (the expressions IPOPT sees), or
        None where :func:`applies` says it does not. ``held``: a start of a problem of
        several free tunables, searched along tunable ``axis`` with the others held at
        the start's values (a grid of that start alone); the search's z is that tunable's.
        ``check``: the problem's :class:`ErrorCheck`, made here if not given."""
        if not (applies(problem) if held is None else applies_along(problem)):
            return None
        at = np.asarray(held if held is not None else [0.0], dtype=float)
        starts = (np.asarray(problem.starts, dtype=float)[:, 0] if held is None else
                  at[axis:axis + 1])
        check = check if check is not None else ErrorCheck(problem)

        def evaluate(z):
            full = at.copy()
            full[axis] = z
            return check.point(full)

        def evaluate_all(zs):  # one call of the check mapped over the points: the same bits
            grid = np.repeat(at[:, None], len(zs), axis=1)
            grid[axis] = zs
            return check.points(grid)

        return cls(evaluate, float(problem.lbw[axis]), float(problem.ubw[axis]), starts,
                   evaluate_all=evaluate_all)

    @property
    def solvable(self) -> bool:
        """Some grid point is feasible."""
        return bool(self.feasible.any())

    def _at(self, z: float):
        """The point (e, bound rows, other) at ``z``, counted as an evaluation of e by the
        search and the start being solved; evaluated once per search and z (the grid's
        points from its call): brentq's bracket ends are points the search has, and a
        crossing's root one brentq evaluated. The count stays the search's reads, as a
        bracket an earlier start searched is charged again."""
        self.evaluations += 1
        self._charged += 1
        key = _key(z)
        point = self._points.get(key)
        if point is None:
            point = self._points[key] = self.evaluate(z)
        return point

    def solve_from(self, z0: float) -> Found | None:
        """The start at ``z0`` (a grid point) solved, or None: declined (module docstring)."""
        self._charged = 0
        try:
            return self._solve(z0)
        except _Declined:
            return None

    def _solve(self, z0: float) -> Found | None:
        """:meth:`solve_from`'s search (None, or :class:`_Declined` raised: declined)."""
        index = int(np.argmin(np.abs(self.grid - z0)))
        run = self._run(index)
        if run is None:
            return None
        left, right, entry = run
        ends: dict[int, tuple | None] = {}

        def end(side):  # (z, e) where the run ends on ``side`` (-1, +1), or None (declined)
            if side not in ends:
                inner = left if side < 0 else right
                outer = inner + side
                ends[side] = ((float(self.grid[inner]), float(self.errors[inner]))
                              if outer < 0 or outer >= len(self.grid) else
                              self._crossing(float(self.grid[inner]), float(self.grid[outer])))
            return ends[side]

        def found(z, vertex=False):
            return Found(float(z), self._charged, vertex)

        if entry is None:  # downhill from the start, as IPOPT's first step
            j = index
            if self.errors[j] == 0:
                return found(self.grid[j])
            direction = 1 if abs(self._at(float(self.grid[j]) + SLOPE_STEP)[0]) < abs(
                self.errors[j]) else -1
        else:  # entered at the crossing facing the start
            edge = end(entry)
            if edge is None:
                return None
            direction, j = -entry, (left if entry < 0 else right)
            if self._rises(edge, direction):
                # a local minimum of |e| at the crossing: IPOPT from such a start (measured on
                # 200 batch specs) stayed there or went on to a root inside, either way: a
                # run with a sign change is left to it, one without ends at the crossing
                if edge[1] * self.errors[j] <= 0 or self._has_root(left, right):
                    return None
                return found(edge[0], True)
            root = self._root(edge, (float(self.grid[j]), float(self.errors[j])))
            if root is not None:
                return found(root)
            if abs(self.errors[j]) >= abs(edge[1]):
                return None  # |e| least between the crossing and the grid: IPOPT
        while True:  # down the grid's |e| in ``direction`` to a sign change or the run's end
            here = (float(self.grid[j]), float(self.errors[j]))
            k = j + direction
            if not left <= k <= right:  # the run's end: a bound of the box or a crossing
                edge = end(direction)
                if edge is None:
                    return None
                if edge[0] == here[0]:  # the box's bound
                    return found(here[0], True) if self._rises(here, -direction) else None
                root = self._root(here, edge)
                if root is not None:
                    return found(root)
                if abs(edge[1]) <= abs(here[1]) and self._rises(edge, -direction) \
                        and not self._has_root(left, right):
                    return found(edge[0], True)
                return None  # see the infeasible start's crossing above
            root = self._root(here, (float(self.grid[k]), float(self.errors[k])))
            if root is not None:
                return found(root)
            if abs(self.errors[k]) >= abs(here[1]):
                return None  # an interior minimum of |e| without a root: IPOPT
            j = k

    def _has_root(self, left: int, right: int) -> bool:
        """e changes sign between grid points ``left`` … ``right``."""
        errors = self.errors[left:right + 1]
        return bool(np.any(errors[:-1] * errors[1:] <= 0))

    def _root(self, a: tuple, b: tuple) -> float | None:
        """The root of e between the points ``a`` and ``b`` ((z, e) each) by brentq to
        ROOT_XTOL, or None without a sign change; :class:`_Declined` where brentq fails
        (see :func:`_brentq`)."""
        (za, ea), (zb, eb) = a, b
        if ea == 0 or eb == 0:
            return za if ea == 0 else zb
        if ea * eb > 0:
            return None
        lower, upper = sorted((za, zb))
        if (lower, upper) in self._roots:  # a bracket an earlier start reached: the same
            root, evaluations = self._roots[lower, upper]  # search, its count charged again
            self._charged += evaluations
            return root
        before = self._charged
        root = _brentq(lambda z: self._at(z)[0], lower, upper)
        if root is None:
            raise _Declined
        self._roots[lower, upper] = (root, self._charged - before)
        return root

    def _rises(self, edge: tuple, inward: int) -> bool:
        """|e| rises from the run's end ``edge`` ((z, e)) over EDGE_STEP in ``inward``
        (±1): the first-order condition of a minimum on that end."""
        step = self._at(edge[0] + inward * EDGE_STEP)
        return _feasible(step) and abs(step[0]) > abs(edge[1])

    def _run(self, index: int) -> tuple[int, int, int | None] | None:
        """(first, last grid index, entry side) of the feasible run the start at grid point
        ``index`` searches: its own (entry None), or for an infeasible start the nearest
        run, entered from its end facing the start (-1: left, +1: right); None without a
        feasible grid point."""
        entry = None
        if not self.feasible[index]:
            feasible = np.flatnonzero(self.feasible)
            if not feasible.size:
                return None
            nearest = feasible[np.argmin(np.abs(self.grid[feasible] - self.grid[index]))]
            entry = 1 if nearest < index else -1
            index = int(nearest)
        left = right = index
        while left > 0 and self.feasible[left - 1]:
            left -= 1
        while right < len(self.grid) - 1 and self.feasible[right + 1]:
            right += 1
        return left, right, entry

    def _crossing(self, inside: float, outside: float) -> tuple[float, float] | None:
        """(z, e) where the feasible set ends between the feasible ``inside`` and the
        infeasible ``outside``: the root of the one bound row violated there (brentq to
        ROOT_XTOL, the feasible side of its bracket kept); None when the boundary is a
        stability or settling condition's (the NLP holds those with a margin: IPOPT's)."""
        point = self._at(outside)
        # narrow to where only bound rows, all defined, are violated: the bound's crossing
        while point[2] > 0 or not math.isfinite(point[0]) or not all(
                math.isfinite(r) for r in point[1]):
            if abs(outside - inside) <= BOUNDARY_XTOL:
                return None
            middle = 0.5 * (inside + outside)
            probe = self._at(middle)
            if _feasible(probe):
                inside = middle
            else:
                outside, point = middle, probe
        rows = point[1]
        row = max(range(len(rows)), key=rows.__getitem__)  # the first largest, as argmax
        root = _brentq(lambda z: self._at(z)[1][row], inside, outside)
        if root is None:
            return None
        # brentq's answer lies within its tolerance (ROOT_XTOL + 4ε|z|) of the crossing, on
        # either side: keep the feasible one of it and a step of twice that towards inside
        step = 2 * (ROOT_XTOL + 4 * np.finfo(float).eps * abs(root))
        for z in (root, root + math.copysign(step, inside - outside)):
            found = self._at(z)
            if _feasible(found):
                return float(z), float(found[0])
        return None


class ErrorCheck:
    """A problem's NLP check Function read as the search's points (e, bound rows, other)
    at log tunables z (module docstring): made once per problem, whose lines along one
    tunable (feedtune.tuner.nlp's ``_root_along``) each read it."""

    def __init__(self, problem):
        from feedtune.tuner.calls import numeric

        self.check = numeric(problem.evaluator.function)
        self.p = problem.param_values[:problem.evaluator.n_params]
        self._dense = all(self.check.dense(i) for i in range(4))  # terms … settling
        # each bound's sides: sign·(bound − v)/size ≤ 0 where it holds, v the bound row's
        # value (its magnitude for a Magnitude)
        sides = [(index, magnitude, bound, sign, max(1.0, abs(b.lower or 0), abs(b.upper or 0)))
                 for index, (b, magnitude) in enumerate(zip(problem.bounds,
                                                            problem.evaluator.bound_magnitude))
                 for bound, sign in ((b.lower, 1.0), (b.upper, -1.0)) if bound is not None]
        columns = list(zip(*sides)) or [()] * 5
        self._row = np.array(columns[0], dtype=int)
        self._magnitude, self._bound, self._sign, self._size = (
            np.array(column, dtype=dtype).reshape(-1, 1)
            for column, dtype in zip(columns[1:], (bool, float, float, float)))
        # one point: the same operations on Python floats (each one correctly rounded
        # operation, as numpy's), without the arrays around three numbers
        self._sides = [(int(r), bool(m), float(b), float(s), float(n))
                       for r, m, b, s, n in sides]

    def point(self, z: np.ndarray) -> tuple:
        """(e, bound rows, other) at the log tunables ``z``."""
        if self._dense:  # read as floats from the evaluation's own result arrays
            terms, bounds, stability, settling = self.check.nonzeros(z, self.p)[:4]
        else:
            terms, bounds, stability, settling = self.check.outputs(z, self.p)[:4]
        values = bounds.ravel().tolist()
        rows = tuple(s * (b - (abs(values[r]) if m else values[r])) / size
                     for r, m, b, s, size in self._sides)
        conditions = stability.ravel().tolist() + settling.ravel().tolist()
        other = (-math.inf if not conditions else
                 math.inf if any(c != c for c in conditions) else -min(conditions))
        return float(terms.flat[0]), rows, other

    def points(self, grid: np.ndarray) -> list[tuple]:
        """:meth:`point` at each column of ``grid`` (n_z × n), from one call of the check
        mapped over them (:func:`mapped`: the same bits)."""
        n = grid.shape[1]
        terms, bounds, stability, settling = mapped(self.check.function, n).outputs(
            grid, np.tile(self.p, n))[:4]
        values = bounds[self._row]
        rows = self._sign * (self._bound - np.where(self._magnitude, np.abs(values),
                                                    values)) / self._size
        conditions = np.vstack([stability, settling])
        other = -conditions.min(axis=0) if conditions.size else np.full(n, -math.inf)
        other = np.where(np.isnan(other), math.inf, other)
        return list(zip(terms[0].tolist(), map(tuple, rows.T.tolist()), other.tolist()))


#: the check Functions mapped over n points, by Function and n, kept while the Function is
_mapped: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_mapped_lock = threading.Lock()


def mapped(function, n: int):
    """The :class:`~feedtune.tuner.calls.NumericCall` of ``function`` mapped over ``n``
    points (``Function.map``: one call evaluates them in turn, the same bits as ``n``
    calls; measured on a batch spec's 17 grid points 417 → 138 µs), built once per
    Function and n."""
    from feedtune.tuner.calls import numeric

    with _mapped_lock:
        maps = _mapped.setdefault(function, {})
        if n not in maps:
            maps[n] = function.map(n)
        return numeric(maps[n])


class _Declined(Exception):
    """A root the search needs could not be found (see :func:`_brentq`): IPOPT's start."""


def _brentq(f: Callable, a: float, b: float) -> float | None:
    """The root of ``f`` in [a, b] by ``scipy.optimize.brentq`` to ROOT_XTOL, or None where it
    fails (a value that is not a number inside the bracket, e.g. an undefined row between
    two defined ends: the start is then IPOPT's)."""
    from scipy import optimize  # imported when used (start-up time)

    def finite(z):
        value = f(z)
        if not math.isfinite(value):
            raise ArithmeticError(value)
        return value

    try:
        return float(optimize.brentq(finite, a, b, xtol=ROOT_XTOL))
    except (ArithmeticError, ValueError, RuntimeError):
        return None


def _feasible(point) -> bool:
    e, rows, other = point
    return bool(math.isfinite(e) and other <= 0 and all(map(_HOLDS, rows)))


#: a bound row holds: r ≤ 0 (False for NaN)
_HOLDS = (0.0).__ge__


def _key(z: float) -> tuple:
    """``z`` as a key of :attr:`RootSearch._points` that tells −0.0 from 0.0."""
    return z, math.copysign(1.0, z)
