"""One free tunable: a bracketing search on the NLP's own functions instead of IPOPT.

With a single free tunable and nothing else to decide (no epigraph slack, no crossing
variable, no exchange points), the NLP is a one-dimensional minimisation on a box. IPOPT
solves it, but pays for what a line does not need: building the solver expands the graph
to SX and differentiates it twice (Koren's sampled-data IAE: a 47k-instruction objective
and a 333k-instruction Hessian, 0.27 s of a 0.54 s tuning), and each of its ~10
iterations evaluates that Hessian. Here the objective and the feasibility conditions are
evaluated as they are (the problem's ``check`` and ``settling`` Functions, not expanded,
0.15 ms a point on that example), and

1. every start and both ends of the box form a grid in ln(tunable); its feasible points
   (stability and settling conditions positive, constraints within their bounds, a finite
   objective) and their local minima are found in one evaluation of the grid;
2. each grid minimum is one start: its bracket (the neighbouring grid points, or the
   feasibility boundary between a neighbour and it, located by bisection) is searched by
   Brent's method (``scipy.optimize.minimize_scalar``, bounded);
3. a grid with one local minimum is unimodal on the grid: one refinement, not one per
   start. Several minima are refined each (at most ``multistart``), and the starts that
   reach the same objective show in the result as IPOPT's multistart would.

Uniqueness: the curvature of the objective (divided by its value where the refinement
began) in ln(tunable) at an interior optimum, by a central second difference, against the
tuner's FLAT_CURVATURE; an optimum on a bound or a feasibility boundary is a vertex and is
unique.

The tuner (:class:`feedtune.tuner.nlp.Problem`) uses it for every problem it
:func:`applies` to, unless the spec gives IPOPT options (then IPOPT is what was asked for);
the result's ``solver.method`` is then ``brent``.

The search sees only the problem's Functions and numbers (duck-typed: ``has_nlp``,
``n_z``, ``lbw``, ``ubw``, ``starts``, ``bounds``, ``evaluator``, ``settling``,
``param_values``, ``settings`` and ``exchange_groups`` of
:class:`feedtune.tuner.nlp.Problem`), never a plant or a metric.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from feedtune.tuner.optimum import FLAT_CURVATURE

#: Brent's tolerance in ln(tunable) [1]: a relative change of the tunable of 1e-10. Brent
#: itself stops at about √ε·|ln x| (≈ 5e-8 for x ≈ 30), the resolution of a smooth minimum
#: from values alone; the objective there is within ~1e-15 (relative) of its minimum.
BRENT_XTOL = 1e-10
BRENT_MAXITER = 200
#: a feasibility boundary is bisected until its bracket is this narrow in ln(tunable) [1]
#: (a relative 1e-10 of the tunable), the feasible end kept: IPOPT holds a constraint to
#: its tol 1e-9 (relative), the same order
BOUNDARY_XTOL = 1e-10
#: step [1] in ln(tunable) (a relative 1e-8 of the tunable) into the box from a bound or a
#: feasibility boundary: an objective that rises over it (by more than its rounding, ~1e-13
#: relative for a sum over samples, i.e. a slope above ~1e-5 per unit of ln x) has its
#: minimum on that edge; flatter edges are left to Brent
EDGE_STEP = 1e-8
#: step [1] in ln(tunable) (0.1 % of the tunable) of the central second difference that
#: measures curvature at the optimum: rounding (values to ~1e-15 relative) then contributes
#: 4·1e-15/h² ≈ 4e-9 to a curvature compared with FLAT_CURVATURE = 1e-6
CURVATURE_STEP = 1e-3


class _OutOfTime(Exception):
    """A start's time limit passed (see :meth:`ScalarSearch.solve_from`)."""


def applies(problem) -> bool:
    """A problem the scalar search solves: one free tunable and no other NLP variable or
    exchange point (a peak or crossing needs IPOPT's exchange rounds)."""
    return bool(problem.has_nlp and problem.n_z == 1 and len(problem.lbw) == 1
                and not problem.exchange_groups)


@dataclass
class Refined:
    """One refined grid minimum: what IPOPT's ``_solve_from`` returns for a start."""

    z: np.ndarray  # [ln tunable]
    status: str
    iterations: int
    vertex: bool  # on a bound of the box or a feasibility boundary
    reference: float = 1.0  # the objective where the search began (its scale)


@dataclass
class ScalarSearch:
    """Grid, bracketing and Brent on a problem with one free tunable (see module docstring).

    ``evaluate(zs)`` returns (objective, violation) arrays at the points ``zs`` [ln
    tunable]: a point is feasible when its violation is ≤ 0 and its objective finite. The
    tuner uses the search only when a grid point is feasible (:attr:`solvable`); without
    one, IPOPT and its restoration look between the points.
    """

    evaluate: object
    lower: float
    upper: float
    starts: np.ndarray
    count: int  # at most this many grid minima are refined (the spec's multistart)
    time_limit: float = math.inf  # [s] per start, as IPOPT's max_wall_time
    grid: np.ndarray = field(init=False)
    values: np.ndarray = field(init=False)
    feasible: np.ndarray = field(init=False)
    violations: np.ndarray = field(init=False)
    evaluations: int = field(init=False, default=0)
    refined: dict = field(init=False, default_factory=dict)  # z of an optimum → Refined
    deadline: float = field(init=False, default=math.inf)  # [s] perf_counter of this start

    def __post_init__(self):
        self.grid = np.unique(np.concatenate([[self.lower, self.upper],
                                              np.clip(self.starts, self.lower, self.upper)]))
        self.values, self.violations = self.evaluate(self.grid)
        self.evaluations += len(self.grid)
        self.feasible = (self.violations <= 0) & np.isfinite(self.values)

    @classmethod
    def for_problem(cls, problem) -> "ScalarSearch | None":
        """The search for ``problem`` on what its NLP sees (its ``evaluator``) and its scaled
        ``settling`` Function, or None when :func:`applies` says it does not."""
        if not applies(problem):
            return None
        p = problem.param_values

        def evaluate(zs):
            zs = np.atleast_1d(np.asarray(zs, dtype=float))
            seen = [problem.evaluator(np.array([z]), p) for z in zs]
            objective = np.array([np.nan if s.objective is None else s.objective for s in seen])
            bounds = np.array([[np.nan if v is None else v for v in s.bounds] for s in seen],
                              dtype=float).reshape(len(zs), -1).T
            conditions = np.array([s.stability for s in seen], dtype=float).reshape(len(zs), -1).T
            settling = np.array([np.asarray(problem.settling(z, p), dtype=float).ravel()
                                 for z in zs]).reshape(len(zs), -1).T
            return objective, violation(bounds, conditions, settling, problem.bounds)

        return cls(evaluate, float(problem.lbw[0]), float(problem.ubw[0]),
                   np.asarray(problem.starts, dtype=float)[:, 0], problem.settings.multistart,
                   problem.settings.time_limit)

    # -- grid --------------------------------------------------------------------------

    def _classify(self, zs):
        self._check_time()
        values, violations = self.evaluate(zs)
        self.evaluations += len(np.atleast_1d(zs))
        feasible = (violations <= 0) & np.isfinite(values)
        return values, feasible

    def minima(self) -> list[int]:
        """Grid indices of the feasible local minima, the lowest first, at most ``count``.

        A neighbour that is infeasible, or beyond the box, counts as higher.
        """
        v = np.where(self.feasible, self.values, np.inf)
        padded = np.concatenate([[np.inf], v, [np.inf]])
        local = [i for i in range(len(v)) if self.feasible[i]
                 and v[i] <= padded[i] and v[i] <= padded[i + 2]]
        # a flat run of equal values is one minimum: keep its first point
        local = [i for i in local if not (i > 0 and i - 1 in local and v[i - 1] == v[i])]
        return sorted(local, key=lambda i: (v[i], i))[:max(self.count, 1)]

    @property
    def solvable(self) -> bool:
        """Some grid point is feasible: the search has a start."""
        return bool(self.feasible.any())

    def start_points(self) -> np.ndarray:
        """The grid minima as starts (rows of one ln tunable)."""
        return self.grid[self.minima()].reshape(-1, 1)

    # -- one start ---------------------------------------------------------------------

    def _bracket_end(self, center: int, neighbour: int) -> tuple[float, bool, float]:
        """(end, on a feasibility boundary, objective there) of the bracket of grid point
        ``center`` towards its infeasible ``neighbour``, by bisection: the first feasible
        midpoint whose objective is no lower than the center's ends the bracket (the minimum
        lies inside); else the bracket narrows to BOUNDARY_XTOL and its feasible end is the
        boundary."""
        inside, outside = float(self.grid[center]), float(self.grid[neighbour])
        inside_value = float(self.values[center])
        while abs(outside - inside) > BOUNDARY_XTOL:
            middle = 0.5 * (inside + outside)
            values, feasible = self._classify(np.array([middle]))
            if not feasible[0]:
                outside = middle
            elif values[0] >= self.values[center]:
                return middle, False, float(values[0])
            else:
                inside, inside_value = middle, float(values[0])
        return inside, True, inside_value

    def refine(self, z0: float) -> Refined:
        """Brent's method in the bracket of the grid point ``z0`` (see module docstring)."""
        from scipy import optimize  # imported when used (start-up time)

        index = int(np.argmin(np.abs(self.grid - z0)))
        if not self.feasible[index]:
            raise ValueError(f"start {z0} is not a feasible grid point (see start_points)")
        ends = []  # (point, on a feasibility boundary, objective there), below and above
        for neighbour in (index - 1, index + 1):
            if not 0 <= neighbour < len(self.grid):
                neighbour = index  # the box's own end
            if self.feasible[neighbour]:
                ends.append((float(self.grid[neighbour]), False, float(self.values[neighbour])))
            else:
                ends.append(self._bracket_end(index, neighbour))
        scale = float(abs(self.values[index])) or 1.0
        worst = max(float(np.max(np.abs(self.values[self.feasible]))), abs(ends[0][2]),
                    abs(ends[1][2])) / scale
        penalty = 2 * worst + 1.0  # above every feasible value of the grid and the bracket

        def objective(z):
            self._check_time()
            value, violation = self.evaluate(np.array([z]))
            self.evaluations += 1
            if violation[0] > 0 or not np.isfinite(value[0]):
                return penalty
            return float(value[0]) / scale

        center = float(self.values[index]) / scale
        edges = []
        for (end, boundary, value), inward in zip(ends, (1.0, -1.0)):
            edge = boundary or end <= self.lower or end >= self.upper
            edges.append(edge)
            # an optimum on a bound or a feasibility boundary: the objective no higher there
            # than at the grid minimum and rising into the box (first-order condition)
            if edge and value / scale <= center and \
                    objective(end + inward * EDGE_STEP) > value / scale:
                return Refined(np.array([end]), "Solve_Succeeded", 0, True, scale)
        (a, _, fa), (c, _, fc) = ends
        result = optimize.minimize_scalar(objective, bounds=(a, c), method="bounded",
                                          options={"xatol": BRENT_XTOL,
                                                   "maxiter": BRENT_MAXITER})
        # the ends are feasible, so the lowest of the three is (an infeasible point scores
        # the penalty, above both ends)
        z, _ = min(((float(result.x), float(result.fun)), (a, fa / scale), (c, fc / scale)),
                   key=lambda p: p[1])
        near = BOUNDARY_XTOL + 4 * BRENT_XTOL + 1e-7 * max(1.0, abs(z))
        vertex = (abs(z - a) <= near and edges[0]) or (abs(z - c) <= near and edges[1])
        status = "Solve_Succeeded" if result.success else "Maximum_Iterations_Exceeded"
        return Refined(np.array([z]), status, int(result.nit), vertex, scale)

    def _check_time(self):
        if time.perf_counter() > self.deadline:
            raise _OutOfTime

    def solve_from(self, start: np.ndarray, started: float | None = None):
        """What ``Problem._solve_from`` returns, for the scalar search: (z, return status,
        iterations, exchange points added (0), None: no IPOPT multipliers).

        ``started`` [s, perf_counter]: the start's clock; past ``time_limit`` after it, the
        search stops at its start with IPOPT's status Maximum_WallTime_Exceeded.
        """
        self.deadline = (started if started is not None else time.perf_counter()) + self.time_limit
        try:
            refined = self.refine(float(start[0]))
        except _OutOfTime:
            refined = Refined(np.array([float(start[0])]), "Maximum_WallTime_Exceeded", 0, False)
        finally:
            self.deadline = math.inf
        self.refined[float(refined.z[0])] = refined
        return refined.z, refined.status, refined.iterations, 0, None

    def flat_tunables(self, z: np.ndarray, name: str) -> list[str]:
        """[name] when the optimum ``z`` (one of :meth:`solve_from`'s) is interior and the
        objective's curvature there, divided by the objective where its search began, is
        below the tuner's FLAT_CURVATURE; else []."""
        near = [k for k in self.refined if abs(k - float(z[0])) <= BOUNDARY_XTOL]
        if not near:
            return []
        refined = self.refined[near[0]]
        if refined.vertex:
            return []
        return [name] if self.curvature(float(z[0]), refined.reference) < FLAT_CURVATURE else []

    def curvature(self, z: float, reference: float) -> float:
        """d²(f/|reference|)/d(ln x)² at ``z`` by a central second difference
        (CURVATURE_STEP); +inf where a neighbour is infeasible."""
        h = CURVATURE_STEP
        values, violations = self.evaluate(np.array([z - h, z, z + h]))
        self.evaluations += 3
        if np.any(violations > 0) or not np.all(np.isfinite(values)):
            return math.inf
        return float((values[0] - 2 * values[1] + values[2]) / h**2 / (abs(reference) or 1.0))


def violation(bounds, conditions, settling, constraints) -> np.ndarray:
    """Largest violation per point (columns): > 0 when a stability or settling condition is
    not positive or a constraint leaves its bounds (relative to max(1, |bound|), as the
    tuner reports violations); ≤ 0 when everything holds."""
    rows = [np.full(conditions.shape[1], -np.inf)]  # every array has one column per point
    if conditions.size:
        rows.append(np.max(-conditions, axis=0))
    if settling.size:
        rows.append(np.max(-settling, axis=0))
    for values, bound in zip(bounds, constraints):
        scale = max(1.0, abs(bound.lower or 0), abs(bound.upper or 0))
        if bound.lower is not None:
            rows.append((bound.lower - values) / scale)
        if bound.upper is not None:
            rows.append((values - bound.upper) / scale)
    worst = np.max(np.vstack(rows), axis=0)
    return np.where(np.isnan(worst), np.inf, worst)
