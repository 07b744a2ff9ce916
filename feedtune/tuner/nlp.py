"""One CasADi NLP per problem, solved by IPOPT from deterministic starting points.

The tuner sees only a loop factory and metric callables; it never names a plant or a
metric. Free tunables are optimised as their logarithms (every tunable is positive, and
gains and periods span decades). Magnitude terms |e| become epigraphs: a slack t with
−t ≤ e ≤ t, so the NLP stays smooth. The loop's Hurwitz/Schur conditions are always
constraints, and the final loop is checked with numpy eigenvalues.

Peaks and crossings over frequency (:class:`~feedtune.expr.Supremum`,
:class:`~feedtune.expr.Crossing`) are semi-infinite constraints. The NLP holds them on a
fixed grid, each point written in a bounded form ((f − c)/(f + c) ≤ 0 for f ≤ c), so no
constraint blows up where a closed-loop pole crosses the jω axis. After each solve the
refined peak (or dip) is evaluated; while it violates the bound, its frequency is added as
one more constraint point (a parameter of the built NLP) and IPOPT runs again from the last solution:
the exchange method. Putting the refined peak itself in the NLP was tried and stalled
IPOPT: its value switches between peaks, so its derivatives jump.

Solver reuse: building the IPOPT solver (``nlpsol``, SX expansion) costs more than most
solves, and batch tuning solves thousands of specs of a few structures in one process.
Every number of a problem that does not shape its graph is therefore an NLP parameter
(``p``): fixed tunable values, the plant's numbers it offers (``numbers``, see
``feedtune.plants.base``), objective weights, constraint bounds inside the graph, and
every scale found by probing the starts. The graph is always built this way, so a result
is the same whether its solver is new or reused. The solver and the Functions of a
problem are cached per process (:func:`solver_cache_info`), keyed by a hash of their
serialized graphs, the nlpsol options and the expand flag: a number still embedded as a
constant (a horizon's sample count, a frequency grid, the sign of a weight) makes a
different key. A problem without free tunables builds no solver and is not cached.
"""

from __future__ import annotations

import hashlib
import json
import math
import threading
import time
from collections import OrderedDict
from dataclasses import dataclass, field
from typing import Callable, Mapping

import casadi as ca
import numpy as np
from scipy import linalg, optimize
from scipy.stats import qmc

from feedtune.expr import Crossing, Magnitude, Supremum
from feedtune.validate.stability import check_stability

STABILITY_MARGIN = 1e-9  # scaled Hurwitz conditions must exceed this
#: a scaled settling condition below this at the optimum means the horizon limited it
SETTLING_ACTIVE = 1e-6
#: expand the NLP to SX (≈4x faster solves, slower build) up to this many unrolled loop steps
AUTO_EXPAND_STEPS = 250
FEASIBILITY_TOL = 1e-6  # relative tolerance when reporting whether a bound holds
RESTORATION_EVALUATIONS = 400  # loop evaluations a start may spend looking for stability
#: frequencies the exchange method may add to one peak or crossing, per start
EXCHANGE_POINTS = 8
#: IPOPT options the tuner always sets, after the caller's: no output (stdout carries the
#: result), and no options file (IPOPT otherwise reads ./ipopt.opt, which may name a
#: library to load)
FIXED_IPOPT_OPTIONS = {"print_level": 0, "sb": "yes", "option_file_name": "",
                       "output_file": "", "file_print_level": 0}
#: options that name a file or library, or choose one to load: refused whatever the caller
LIBRARY_IPOPT_OPTIONS = frozenset({"hsllib", "pardisolib", "linear_solver",
                                   "linear_system_scaling", "nlp_scaling_method"})
SAFE_LIBRARY_CHOICES = frozenset({"mumps", "none", "slack-based", "gradient-based"})
#: a refined peak above its bound (relative), or a dip below a crossing condition's zero
#: (the condition is bounded, so absolute), by more than this adds its frequency
EXCHANGE_TOL = 1e-7
#: a crossing's condition must exceed DIP_MARGIN·(1 − x) at ω = b·x below b: without it the
#: optimiser parks a dip exactly on the level (a tangency) and claims the crossing beyond
#: it, where any rounding puts the first crossing at the dip (measured on Bhatia's showcase:
#: 690 rad/s claimed, 471 rad/s by python-control)
DIP_MARGIN = 1e-3
#: the objective (divided by its value at the start) curves less than this along a direction
#: of ln(tunables) allowed by the active constraints: a flat direction, the optimum not unique
FLAT_CURVATURE = 1e-6
#: a multiplier larger than this (relative to 1 and the largest) makes its constraint active
ACTIVE_MULTIPLIER = 1e-6
#: a tunable moves along a flat direction when its share of the direction exceeds this
FLAT_SHARE = 0.1
#: two starts reach the same optimum when their objectives differ by less than this,
#: relative to the larger of the best objective and the objective's scale at the starts
SAME_OPTIMUM_TOL = 1e-6

_STATUS = {
    "Solve_Succeeded": "optimal",
    "Solved_To_Acceptable_Level": "acceptable",
    "Infeasible_Problem_Detected": "infeasible",
    "Maximum_Iterations_Exceeded": "iteration_limit",
    "Maximum_CpuTime_Exceeded": "time_limit",
    "Maximum_WallTime_Exceeded": "time_limit",
    "Exchange_Points_Exhausted": "iteration_limit",  # feedtune's: see Problem._solve_from
    "No_Stable_Start": "infeasible",  # feedtune's: restoration found no stable point
}
SOLVED = ("optimal", "acceptable")


@dataclass(frozen=True)
class Variable:
    """A free tunable, optimised as ln(value) within [lower, upper] (both > 0)."""

    name: str
    lower: float
    upper: float
    initial: float | None = None


@dataclass(frozen=True)
class Term:
    """Objective term ``weight · value(loop)``; ``value`` may return a Magnitude."""

    label: str
    value: Callable
    weight: float = 1.0


@dataclass(frozen=True)
class Bound:
    """Constraint ``lower ≤ value(loop) ≤ upper`` (None: unbounded on that side)."""

    label: str
    value: Callable
    lower: float | None
    upper: float | None


@dataclass(frozen=True)
class Settings:
    multistart: int = 8
    max_iter: int = 500
    tol: float = 1e-9
    time_limit: float = 60.0
    expand: bool | None = None
    ipopt_options: Mapping[str, object] = field(default_factory=dict)

    def __post_init__(self):
        """Refuse IPOPT options that would load a library, whoever built the settings (a
        spec's options are allow-listed by :mod:`feedtune.spec` before they get here)."""
        for name, value in self.ipopt_options.items():
            if name in LIBRARY_IPOPT_OPTIONS and value not in SAFE_LIBRARY_CHOICES:
                raise ValueError(f"IPOPT option {name} = {value!r} would load a library")


@dataclass
class StartOutcome:
    index: int
    status: str
    return_status: str
    objective: float | None
    iterations: int
    solve_time: float
    feasible: bool
    exchange_points: int = 0


@dataclass
class Outcome:
    """What the tuner found: the best start, and what every start did."""

    status: str
    return_status: str
    message: str
    success: bool
    values: dict[str, float]
    objective: float | None
    reports: dict[str, float | None]
    constraints: list[tuple[Bound, float | None, bool]]
    stability: dict
    iterations: int
    solve_time: float
    build_time: float
    evaluation_time: float
    model_gap: float
    horizon_bound: bool  # the optimum lies on the loop's settling conditions: lengthen it
    starts: list[StartOutcome]
    method: str = "ipopt"  # the solver that produced it
    #: every start that reached the best objective, the best first: (index, free tunables)
    equal_optima: list[tuple[int, dict[str, float]]] = field(default_factory=list)
    #: tunables along a flat direction at the optimum (None: not examined)
    flat_tunables: list[str] | None = None


def _number(x) -> float | None:
    value = float(x)
    return value if math.isfinite(value) else None


def _within(value: float | None, lower: float | None, upper: float | None) -> bool:
    if value is None:
        return False
    if lower is not None and value < lower - FEASIBILITY_TOL * max(1.0, abs(lower)):
        return False
    if upper is not None and value > upper + FEASIBILITY_TOL * max(1.0, abs(upper)):
        return False
    return True


def _magnitude(value):
    """(expression, is |·|): the exact value the result reports, for any metric value."""
    if isinstance(value, Magnitude):
        return value.expr, True
    if isinstance(value, (Supremum, Crossing)):
        return value.exact, False
    return value, False


def starting_points(variables: list[Variable], count: int) -> np.ndarray:
    """Deterministic starts in log space: the initial/mid point, then a Halton sequence."""
    if not variables:
        return np.zeros((1, 0))
    lower = np.log([v.lower for v in variables])
    upper = np.log([v.upper for v in variables])
    first = np.array([math.log(v.initial) if v.initial else (lo + hi) / 2
                      for v, lo, hi in zip(variables, lower, upper)])
    points = [first]
    if count > 1:
        unit = qmc.Halton(len(variables), scramble=False).random(count)[1:]
        points.extend(lower + unit * (upper - lower))
    return np.array(points[:count])


#: built problems (nlpsol and Functions) kept per process, least recently used dropped first
SOLVER_CACHE_SIZE = 16


@dataclass
class _Built:
    """What a problem structure costs to build: its Functions and its IPOPT solver."""

    functions: dict
    solver: object  # the nlpsol, or None without free tunables
    reused: bool = False


_cache: OrderedDict[str, _Built] = OrderedDict()
_cache_counts = {"hits": 0, "misses": 0}
_cache_lock = threading.Lock()  # the dict and counters only; a build runs unlocked


def solver_cache_info() -> dict[str, int]:
    """Hits, misses, current size and capacity of this process's solver cache."""
    return {**_cache_counts, "size": len(_cache), "maxsize": SOLVER_CACHE_SIZE}


def clear_solver_cache() -> None:
    """Empty this process's solver cache and reset its counters."""
    with _cache_lock:
        _cache.clear()
        _cache_counts.update(hits=0, misses=0)


def structure_key(functions: Mapping[str, ca.Function], options: Mapping, expand: bool) -> str:
    """SHA-256 of the serialized Functions, the nlpsol options and the expand flag.

    Every number that is not an NLP parameter is a constant inside the serialized graph, so
    two problems share a key only when their solvers compute the same thing.
    """
    digest = hashlib.sha256()
    for name in sorted(functions):
        digest.update(name.encode())
        digest.update(functions[name].serialize().encode())
    digest.update(json.dumps([options, bool(expand)], sort_keys=True, default=repr).encode())
    return digest.hexdigest()


def _nlpsol(nlp: ca.Function, options: Mapping, expand: bool):
    """IPOPT on ``nlp``, expanded to SX when asked and possible."""
    if expand:
        try:
            return ca.nlpsol("feedtune", "ipopt", nlp, {**options, "expand": True})
        except RuntimeError:  # a node without an SX form (e.g. a rootfinder)
            pass
    return ca.nlpsol("feedtune", "ipopt", nlp, dict(options))


def _cached_build(functions: dict, probe: ca.Function, options: Mapping, expand: bool,
                  has_nlp: bool) -> _Built:
    """The Functions and solver of this structure: from the cache when an identical graph
    was built before in this process, else ``functions`` with a new solver (then cached).

    Without free tunables there is no solver to build and nothing is cached.
    """
    if not has_nlp:
        return _Built(functions, None)
    key = structure_key({**functions, "probe": probe}, options, expand)
    with _cache_lock:
        built = _cache.get(key)
        if built is not None:
            _cache.move_to_end(key)
            _cache_counts["hits"] += 1
            return _Built(built.functions, built.solver, reused=True)
        _cache_counts["misses"] += 1
    built = _Built(functions, _nlpsol(functions["nlp"], options, expand))
    with _cache_lock:
        _cache[key] = built
        while len(_cache) > SOLVER_CACHE_SIZE:
            _cache.popitem(last=False)
    return built


class Problem:
    """The NLP, built once (or taken from the solver cache); :meth:`solve` runs the multistart.

    ``make_loop(values)`` builds the loop from tunable values; with free tunables it is
    called as ``make_loop(values, lifted)`` when ``numbers`` (name → value, e.g. a plant's
    time constant) is not empty, ``lifted`` mapping each name to its NLP parameter.
    """

    def __init__(self, variables: list[Variable], fixed: Mapping[str, float],
                 make_loop: Callable, objective: list[Term], constraints: list[Bound],
                 reports: Mapping[str, Callable], settings: Settings,
                 numbers: Mapping[str, float] | None = None):
        started = time.perf_counter()
        self.variables, self.fixed, self.settings = variables, dict(fixed), settings
        self.objective_terms, self.bounds = objective, constraints
        self.has_nlp = bool(variables)
        z = ca.MX.sym("log_tunables", len(variables))
        # every number of the problem that shapes no graph is an NLP parameter (see
        # "Solver reuse" in the module docstring): the symbols, and this spec's values
        params, param_values = [], []

        def parameter(name, value):
            symbol = ca.MX.sym(name)
            params.append(symbol)
            param_values.append(float(value))
            return symbol

        values = {v.name: ca.exp(z[i]) for i, v in enumerate(variables)}
        if self.has_nlp:
            values.update({name: parameter(f"fixed_{name}", value) for name, value in fixed.items()})
            lifted = {name: parameter(f"number_{name}", value)
                      for name, value in (numbers or {}).items()}
            loop = make_loop(values, lifted) if lifted else make_loop(values)
        else:  # nothing to solve, nothing to reuse: a loop of numbers, as evaluated exactly
            values.update({name: ca.MX(value) for name, value in fixed.items()})
            loop = make_loop(values)
        self.discrete = loop.discrete

        weights = [parameter(f"weight{i}", t.weight) for i, t in enumerate(objective)]
        term_values = [t.value(loop) for t in objective]
        bound_values = [b.value(loop) for b in constraints]
        term_exprs = [(_magnitude(v), w) for v, w in zip(term_values, weights)]
        bound_exprs = [_magnitude(v) for v in bound_values]
        stability = loop.stability_conditions()
        settling = loop.settling_conditions()  # after the terms: they say what was summed
        raw_objective = sum((w * (ca.fabs(e) if mag else e) for (e, mag), w in term_exprs), ca.MX(0))
        # scales: the smallest magnitude each expression takes over the stable starts. An
        # unstable loop's IAE is astronomically large; scaling by it would flatten the
        # objective until IPOPT stops anywhere (too small a scale is harmless: IPOPT's
        # gradient-based scaling shrinks large gradients). No stable start: no scaling.
        self.starts = starting_points(variables, settings.multistart)
        model_params = ca.vertcat(ca.MX(0, 1), *params)
        probe = ca.Function("probe", [z, model_params], [ca.vertcat(
            raw_objective, *[e for (e, _), _ in term_exprs], *[e for e, _ in bound_exprs],
            *stability, *settling)])
        model_values = np.array(param_values, dtype=float)
        table = np.column_stack([np.asarray(probe(z0, model_values), dtype=float).ravel()
                                 for z0 in self.starts])
        first_stability = 1 + len(term_exprs) + len(bound_exprs)
        stable = np.all(table[first_stability:first_stability + len(stability)] > 0, axis=0)
        table = np.abs(table)
        table[~np.isfinite(table) | (table == 0)] = np.inf
        table[:first_stability, ~stable] = np.inf
        smallest = [float(v) if math.isfinite(v) else None for v in table.min(axis=1)]
        f_ref, numbers_ref = smallest[0], smallest[1:]
        term_ref = numbers_ref[:len(term_exprs)]
        bound_ref = numbers_ref[len(term_exprs):len(term_exprs) + len(bound_exprs)]
        stab_ref = numbers_ref[len(term_exprs) + len(bound_exprs):][:len(stability)]
        settle_ref = numbers_ref[len(term_exprs) + len(bound_exprs) + len(stability):]

        def scale(*candidates):
            finite = [abs(c) for c in candidates if c is not None and math.isfinite(c) and c != 0]
            return max(finite) if finite else 1.0

        f_scale = scale(f_ref)
        # variables beyond the tunables: (symbol, lower, upper, start value as a function of z)
        extra, extra_lower, extra_upper, extra_start = [], [], [], []
        f = ca.MX(0)
        g, lbg, ubg = [], [], []

        def add_variable(name, lower, upper, start):
            symbol = ca.MX.sym(name)
            extra.append(symbol)
            extra_lower.append(lower)
            extra_upper.append(upper)
            extra_start.append(start)
            return symbol

        def constrain(expr, lower, upper):
            g.append(expr)
            lbg.append(lower)
            ubg.append(upper)

        # exchange points: parameters of the NLP (ω, or x = ω/b for a crossing) whose rows
        # are switched on by their bounds when the refined check adds them
        slots, slot_defaults, checks = [], [], []
        self._exchange = []  # per peak/crossing: (row bounds when on, slot indices, row indices)

        def exchange_rows(bounds, default, constraint_at, check):
            indices, rows = [], []
            for _ in range(EXCHANGE_POINTS):
                symbol = ca.MX.sym(f"exchange{len(slots)}")
                indices.append(len(slots))
                slots.append(symbol)
                slot_defaults.append(default)
                rows.append(len(g))
                constrain(constraint_at(symbol), -ca.inf, ca.inf)  # off until added
            self._exchange.append((bounds, indices, rows))
            checks.extend(check)

        def crossing_variable(value, index, equality):
            """b = exp(u): condition(b·x) ≥ DIP_MARGIN·(1 − x) on the grid and at exchange
            points; condition(b) = 0 when b must be the crossing itself, ≥ 0 when it is
            maximised or bounded below."""
            lo, hi = value.band
            u = add_variable(f"log_crossing{index}", math.log(lo), math.log(hi),
                             ca.log(value.exact))
            b = ca.exp(u)
            constrain(value.condition(b), 0, 0 if equality else ca.inf)

            def row(x):
                return value.condition(b * x) - DIP_MARGIN * (1 - x)

            for x in value.relative_grid:
                constrain(row(x), 0, ca.inf)
            dip, where = value.lowest_minimum(b, DIP_MARGIN)
            exchange_rows((0, ca.inf), float(value.relative_grid[0]), row, [-dip, where / b])
            return b

        def supremum_below(value, bound, s, positive):
            """value.fn(ω) ≤ bound on the grid and at exchange points (Supremum), written
            (fn − bound)/(fn + bound) ≤ 0 when the bound is positive: bounded in [−1, 1]."""
            def row(omega):
                v = value.fn(omega)
                return (v - bound) / (v + bound) if positive else (v - bound) / s

            for omega in value.grid:
                constrain(row(omega), -ca.inf, 0)
            exchange_rows((-ca.inf, 0), float(value.grid[0]), row,
                          [(value.exact - bound) / (ca.fabs(bound) + 1e-300), value.argmax])

        for index, (value, ((expr, mag), weight), term, ref) in enumerate(
                zip(term_values, term_exprs, objective, term_ref)):
            sign = term.weight  # its sign shapes the NLP; its size is the parameter ``weight``
            if isinstance(value, Crossing):
                f += weight * crossing_variable(value, index, equality=sign > 0)
            elif isinstance(value, Supremum) and sign > 0:  # epigraph: fn(ω) ≤ s·t, minimise
                s = parameter(f"term_scale{index}", scale(ref))
                t = add_variable(f"peak{index}", 0, ca.inf, value.exact / s * 1.01)
                supremum_below(value, s * t, s, positive=True)
                f += weight * s * t
            elif mag and sign < 0:  # maximising |e|: no epigraph bounds it from above
                f += weight * ca.fabs(expr)
            elif mag:  # epigraph: −s·t ≤ e ≤ s·t, minimise s·t
                s = parameter(f"term_scale{index}", scale(ref))
                t = add_variable(f"slack{index}", 0, ca.inf, ca.fabs(expr) / s * 1.01 + 1e-6)
                f += weight * s * t
                constrain((expr - s * t) / s, -ca.inf, 0)
                constrain((expr + s * t) / s, 0, ca.inf)
            else:
                f += weight * expr
        for index, (value, (expr, mag), bound, ref) in enumerate(
                zip(bound_values, bound_exprs, constraints, bound_ref)):
            s_value = scale(bound.lower, bound.upper) if (bound.lower or bound.upper) else scale(ref)
            s = parameter(f"bound_scale{index}", s_value)
            lower = bound.lower / s_value if bound.lower is not None else -ca.inf
            upper = bound.upper / s_value if bound.upper is not None else ca.inf
            if isinstance(value, Crossing):
                b = crossing_variable(value, f"_bound{index}", equality=bound.upper is not None)
                constrain(b / s, lower, upper)
            elif isinstance(value, Supremum) and bound.upper is not None:
                supremum_below(value, parameter(f"bound_upper{index}", bound.upper), s,
                               positive=bound.upper > 0)
                if bound.lower is not None:
                    constrain(expr / s, lower, ca.inf)
            elif mag and bound.lower is not None and bound.lower > 0:
                constrain(expr**2 / s**2, lower**2, upper**2 if bound.upper is not None else ca.inf)
            elif mag:
                constrain(expr / s, -upper, upper)
            else:
                constrain(expr / s, lower, upper)
        stability_rows = [ca.asinh(c / parameter(f"stability_scale{i}", scale(ref)))
                          for i, (c, ref) in enumerate(zip(stability, stab_ref))]
        scaled_settling = [c / parameter(f"settling_scale{i}", scale(ref))
                           for i, (c, ref) in enumerate(zip(settling, settle_ref))]
        for condition in stability_rows + scaled_settling:
            constrain(condition, STABILITY_MARGIN, ca.inf)

        self.n_z = len(variables)
        w = ca.vertcat(z, *extra)
        p = ca.vertcat(ca.MX(0, 1), *params)
        self.param_values = np.array(param_values, dtype=float)
        self.lbw = np.concatenate([np.log([v.lower for v in variables]), extra_lower])
        self.ubw = np.concatenate([np.log([v.upper for v in variables]), extra_upper])
        self.lbg, self.ubg = np.array(lbg, dtype=float), np.array(ubg, dtype=float)
        self.slot_defaults = np.array(slot_defaults, dtype=float)
        self._options = {
            "ipopt": {"max_iter": settings.max_iter, "tol": settings.tol,
                      "max_wall_time": settings.time_limit, **settings.ipopt_options,
                      **FIXED_IPOPT_OPTIONS},
            "print_time": False,
            "error_on_fail": False,
        }
        expand = settings.expand
        if expand is None:  # auto: expansion pays for itself on short horizons only
            expand = loop.unrolled_steps <= AUTO_EXPAND_STEPS
        # the objective is divided by its value at each start (a parameter, so one build
        # serves every start); a start that is not stable is first moved to a stable point
        # nearby (restoration, see _stable_start), where that value means something
        objective_scale = ca.MX.sym("objective_scale")
        matrices = loop.stability_matrices()
        self.matrix_names = list(matrices)
        functions = {
            "nlp": ca.Function("nlp", [w, ca.vertcat(objective_scale, *slots, p)],
                               [f / objective_scale, ca.vertcat(*g)], ["x", "p"], ["f", "g"]),
            "settling": ca.Function("settling", [z, p], [ca.vertcat(ca.MX(0, 1), *scaled_settling)]),
            "extra_start": ca.Function("extra_start", [z, p],
                                       [ca.vertcat(ca.MX(0, 1), *extra_start)]),
            # per exchange group: (violation, where) at a solution of the NLP
            "exchange_check": ca.Function("exchange_check", [z, *extra, p],
                                          [ca.vertcat(ca.MX(0, 1), *checks)]),
            "check": ca.Function(
                "check", [z, p],
                [raw_objective,
                 ca.vertcat(ca.MX(0, 1), *[ca.fabs(e) if m else e for e, m in bound_exprs]),
                 ca.vertcat(*stability), *matrices.values()]),
            # conditions and matrices alone: what restoration evaluates hundreds of times
            "stability_check": ca.Function("stability_check", [z, p],
                                           [ca.vertcat(*stability), *matrices.values()]),
        }
        entry = _cached_build(functions, probe, self._options, expand, self.has_nlp)
        self.settling = entry.functions["settling"]
        self.extra_start = entry.functions["extra_start"]
        self._exchange_check = entry.functions["exchange_check"]
        self.check = entry.functions["check"]
        self.stability_check = entry.functions["stability_check"]
        self._nlpsol = entry.solver
        self.solver_reused = entry.reused
        self.f_scale = f_scale
        self.make_loop, self.reports = make_loop, dict(reports)
        self.build_time = time.perf_counter() - started

    def _evaluate(self, z_value):
        """What the NLP sees at ``z_value``: objective, bound values, conditions, matrices."""
        objective, bounds, conditions, *matrices = self.check(z_value, self.param_values)
        bounds = [_number(b) for b in np.asarray(bounds).ravel()]
        matrices = {name: np.asarray(m, dtype=float) for name, m in zip(self.matrix_names, matrices)}
        return _number(objective), bounds, np.asarray(conditions).ravel(), matrices

    def _evaluate_numeric(self, values: Mapping[str, float]):
        """Objective, bounds, conditions, matrices and reports on the loop built from numbers.

        A loop of numbers may size itself exactly (e.g. integrate a step response until it
        has settled), so these are the values a result reports.
        """
        loop = self.make_loop(dict(values))

        def number(value):
            expr, mag = _magnitude(value)
            return _number(ca.fabs(ca.evalf(expr)) if mag else ca.evalf(expr))

        terms = [number(t.value(loop)) for t in self.objective_terms]
        objective = (None if any(v is None for v in terms)
                     else sum(t.weight * v for t, v in zip(self.objective_terms, terms)))
        bounds = [number(b.value(loop)) for b in self.bounds]
        conditions = np.array([float(ca.evalf(c)) for c in loop.stability_conditions()])
        matrices = {name: np.array(ca.evalf(m), dtype=float)
                    for name, m in loop.stability_matrices().items()}
        reports = {key: number(fn(loop)) for key, fn in self.reports.items()}
        return objective, bounds, conditions, matrices, reports

    def _feasible(self, bounds, conditions, matrices) -> tuple[bool, dict]:
        """Constraints hold and every loop is stable by numpy eigenvalues and by its conditions.

        The result's stability block describes the closed loop; loops that must also be
        stable on their own (e.g. an inner velocity loop) appear under their names.
        """
        checks = {name: check_stability(m, self.discrete) for name, m in matrices.items()}
        numeric = checks.pop("closed_loop")
        hurwitz_ok = bool(np.all(conditions > 0))
        stability = {**numeric, **checks, "conditions_hold": hurwitz_ok}
        stability["stable"] = bool(numeric["stable"] and hurwitz_ok
                                   and all(c["stable"] for c in checks.values()))
        ok = stability["stable"] and all(_within(v, b.lower, b.upper) for v, b in zip(bounds, self.bounds))
        return ok, stability

    def solve(self, progress: Callable[[StartOutcome, int], None] | None = None) -> Outcome:
        """Run every start; ``progress(start_outcome, total)`` is called after each."""
        starts: list[StartOutcome] = []
        best = None  # (key, index, z, stats)
        optima = []  # (index, objective, z) of every start that solved feasibly
        kkt = {}  # index: the start's last NLP solution and multipliers (see _flat_tunables)
        for index, z0 in enumerate(self.starts):
            started = time.perf_counter()
            if self.has_nlp:
                z_opt, return_status, iterations, exchanged, kkt[index] = self._solve_from(
                    z0, started)
                status = _STATUS.get(return_status, "error")
            else:
                z_opt, return_status, status, iterations = z0, "No_Free_Tunables", "optimal", 0
                exchanged = 0
            elapsed = time.perf_counter() - started
            objective, bounds, conditions, matrices = self._evaluate(z_opt)
            feasible, _ = self._feasible(bounds, conditions, matrices)
            if return_status == "No_Stable_Start":  # nothing was solved: no objective to show
                objective = None
            starts.append(StartOutcome(index, status, return_status, objective, iterations,
                                       elapsed, feasible, exchanged))
            if progress is not None:
                progress(starts[-1], len(self.starts))
            violation = self._violation(bounds, conditions)
            solved = status in SOLVED and feasible and objective is not None
            key = (0, objective, index) if solved else (1, violation, index)
            if solved:
                optima.append((index, objective, z_opt))
            if best is None or self._better(key, best[0]):
                best = (key, index, z_opt, return_status, status)
        _, index, z_opt, return_status, status = best
        equal_optima = self._equal_optima(optima, index)
        flat = self._flat_tunables(*kkt[index]) if kkt.get(index) else None
        started = time.perf_counter()
        values = {v.name: float(math.exp(z_opt[i])) for i, v in enumerate(self.variables)}
        values.update(self.fixed)
        objective, bounds, conditions, matrices, reports = self._evaluate_numeric(values)
        feasible, stability = self._feasible(bounds, conditions, matrices)
        model_gap = self._model_gap(self._evaluate(z_opt), objective, bounds)
        settling = np.asarray(self.settling(z_opt, self.param_values), dtype=float).ravel()
        horizon_bound = bool(np.any(settling < SETTLING_ACTIVE))
        evaluation_time = time.perf_counter() - started
        success = status in SOLVED and feasible and objective is not None
        if status in SOLVED and feasible and objective is None:
            status = "error"
            message = ("the objective is not a finite number at the tuned point (an input far "
                       "outside the model's range?)")
        elif success:
            message = f"start {index + 1} of {len(starts)} gave the best feasible optimum"
        elif status in SOLVED:
            status = "infeasible"
            broken = [b.label for v, b in zip(bounds, self.bounds) if not _within(v, b.lower, b.upper)]
            if not stability["stable"]:
                inner = [name for name, check in stability.items()
                         if isinstance(check, dict) and not check["stable"]]
                broken += [f"{name.replace('_', ' ')} stability" for name in inner]
                if not inner or not stability["conditions_hold"]:
                    broken.append("closed-loop stability")
            message = "no start satisfied every constraint; violated: " + ", ".join(broken)
        elif all(s.return_status == "No_Stable_Start" for s in starts):
            message = (f"no stable start: none of the {len(starts)} starts has a stable loop "
                       "within reach (restoration searched near each); widen the tunables' "
                       "bounds towards a stable design, or give a stable 'initial' point")
        else:
            message = f"no start converged; best attempt (start {index + 1}) ended with {return_status}"
        return Outcome(
            status=status, return_status=return_status, message=message, success=success,
            values=values, objective=objective,
            reports=reports,
            constraints=[(b, v, _within(v, b.lower, b.upper)) for b, v in zip(self.bounds, bounds)],
            stability=stability, iterations=starts[index].iterations,
            solve_time=sum(s.solve_time for s in starts), build_time=self.build_time,
            evaluation_time=evaluation_time, model_gap=model_gap, horizon_bound=horizon_bound,
            starts=starts, equal_optima=equal_optima if success else [],
            flat_tunables=flat if success else None)

    def _flat_tunables(self, x, p, lam_g, lam_x, lbg, ubg) -> list[str]:
        """Tunables that move along a flat direction of the NLP's solution ``x``.

        Second-order conditions: the Hessian of the Lagrangian (IPOPT's own, with its
        multipliers) reduced to the directions that keep every active constraint and bound
        (a multiplier above ACTIVE_MULTIPLIER, or an equality) unchanged to first order. A
        reduced curvature below FLAT_CURVATURE (the objective is divided by its value at
        the start, the tunables are logarithms) is a direction in which the optimum is not
        unique, e.g. zero radial error along a curve K(T).
        """
        threshold = ACTIVE_MULTIPLIER * max(1.0, float(np.max(np.abs(lam_g), initial=0.0)),
                                            float(np.max(np.abs(lam_x), initial=0.0)))
        _, jacobian = self._nlpsol.get_function("nlp_jac_g")(x, p)
        rows = [i for i in range(len(lbg)) if (lbg[i] == ubg[i] and math.isfinite(lbg[i]))
                or (abs(lam_g[i]) > threshold and (math.isfinite(lbg[i]) or math.isfinite(ubg[i])))]
        active = np.vstack([np.asarray(jacobian.full())[rows].reshape(len(rows), len(x)),
                            np.eye(len(x))[np.abs(lam_x) > threshold]])
        directions = linalg.null_space(active) if len(active) else np.eye(len(x))
        if directions.shape[1] == 0:
            return []  # a vertex: the active constraints fix every variable
        triu = np.asarray(self._nlpsol.get_function("nlp_hess_l")(x, p, 1.0, lam_g).full())
        hessian = triu + np.triu(triu, 1).T
        curvature, vectors = np.linalg.eigh(directions.T @ hessian @ directions)
        flat = set()
        for value, vector in zip(curvature, vectors.T):
            direction = directions @ vector
            tunables = direction[:self.n_z]
            if value < FLAT_CURVATURE and np.linalg.norm(tunables) > FLAT_SHARE * np.linalg.norm(direction):
                share = np.abs(tunables) / np.linalg.norm(tunables)
                flat.update(v.name for v, c in zip(self.variables, share) if c > FLAT_SHARE)
        return [v.name for v in self.variables if v.name in flat]

    def _equal_optima(self, optima, best_index) -> list[tuple[int, dict[str, float]]]:
        """The starts whose optimum has the best start's objective, the best first, with
        their free tunables.

        Equal: objectives within SAME_OPTIMUM_TOL of the larger of |best| and the objective's
        scale at the starts (an optimum of 0, e.g. a radial error, is compared against the
        error the starts had, not against itself).
        """
        best = next((objective for i, objective, _ in optima if i == best_index), None)
        if best is None:
            return []
        tolerance = SAME_OPTIMUM_TOL * max(abs(best), self.f_scale)
        equal = sorted((i != best_index, i, z) for i, objective, z in optima
                       if abs(objective - best) <= tolerance)
        return [(i, {v.name: float(math.exp(z[k])) for k, v in enumerate(self.variables)})
                for _, i, z in equal]

    def _solve_from(self, start: np.ndarray, started: float) -> tuple:
        """One start: IPOPT, then exchange rounds while a refined peak or dip violates its bound.

        Returns the tunables' logarithms, IPOPT's last return status, the iterations of
        every round, the number of exchange points added and the last round's solution
        with its multipliers and bounds (see :meth:`_flat_tunables`; None if none ran). A round that does not solve
        ends the start with its status; so do the start's time limit (``time_limit``),
        running out of exchange points, and a start that restoration cannot make stable.
        """
        z0 = self._stable_start(start)
        if z0 is None:  # IPOPT from an unstable point only wanders (measured: Bhatia's showcase)
            return start, "No_Stable_Start", 0, 0, None
        solver = self._nlpsol
        slots = self.slot_defaults.copy()
        lbg, ubg = self.lbg.copy(), self.ubg.copy()
        used = [0] * len(self._exchange)
        x0, p_scale, iterations = self._x0(z0), self._scale_at(z0), 0
        while True:
            solution = solver(x0=x0, p=np.concatenate([[p_scale], slots, self.param_values]),
                              lbx=self.lbw, ubx=self.ubw, lbg=lbg, ubg=ubg)
            stats = solver.stats()
            # IPOPT leaves iter_count unset (garbage) when it stops before iterating
            iterations += min(max(int(stats.get("iter_count", 0)), 0), self.settings.max_iter)
            return_status = stats.get("return_status", "unknown")
            x0 = np.asarray(solution["x"], dtype=float).ravel()
            kkt = (x0, np.concatenate([[p_scale], slots, self.param_values]),
                         np.asarray(solution["lam_g"], dtype=float).ravel(),
                         np.asarray(solution["lam_x"], dtype=float).ravel(), lbg.copy(), ubg.copy())
            if _STATUS.get(return_status) not in SOLVED:
                break
            added = self._add_exchange_points(x0, slots, lbg, ubg, used)
            if added is None:
                return_status = "Exchange_Points_Exhausted"
                break
            if not added:
                break
            if time.perf_counter() - started > self.settings.time_limit:
                return_status = "Maximum_WallTime_Exceeded"
                break
        return x0[:self.n_z], return_status, iterations, sum(used), kkt

    def _add_exchange_points(self, x, slots, lbg, ubg, used) -> bool | None:
        """Switch on a constraint row at every violated refined peak/dip of solution ``x``.

        True when points were added, False when nothing is violated, None when a group that
        needs one has no point left.
        """
        split = [x[:self.n_z], *x[self.n_z:]]
        checks = np.asarray(self._exchange_check(*split, self.param_values), dtype=float).ravel()
        added = False
        for group, (bounds, indices, rows) in enumerate(self._exchange):
            violation, where = checks[2 * group], checks[2 * group + 1]
            if not (violation > EXCHANGE_TOL and math.isfinite(where) and where > 0):
                continue
            if used[group] == len(indices):
                return None
            slot, row = indices[used[group]], rows[used[group]]
            slots[slot] = where
            lbg[row], ubg[row] = bounds
            used[group] += 1
            added = True
        return added

    def _stable_start(self, z0: np.ndarray) -> np.ndarray | None:
        """``z0`` if its loop is stable, else a stable point near it, or None.

        Restoration minimises the largest Re λ/|λ| (|λ| − 1 for a sampled loop) of every
        loop that must be stable, plus a pull towards ``z0``, with Nelder–Mead in the log
        tunables, stopping at the first point whose eigenvalues and stability conditions
        both hold. Derivative-free on purpose: an NLP on the Hurwitz conditions stalled
        (their frequency-balanced form is not monotone in a gain, measured: −1.62 at
        K'_p = 900, −1.85 at 500, +0.98 at 120 on Bhatia's drive).
        """
        def evaluate(z):
            conditions, *matrices = self.stability_check(z, self.param_values)
            return (np.asarray(conditions, dtype=float).ravel(),
                    [np.asarray(m, dtype=float) for m in matrices])

        def stable(z):
            conditions, matrices = evaluate(z)
            return np.all(conditions > 0) and all(
                check_stability(m, self.discrete)["stable"] for m in matrices)

        if stable(z0):
            return z0
        lower, upper = self.lbw[:self.n_z], self.ubw[:self.n_z]
        found = []

        def instability(z):
            matrices = evaluate(z)[1]
            if not all(np.all(np.isfinite(m)) for m in matrices):
                return 1e3
            poles = np.concatenate([np.linalg.eigvals(m) for m in matrices])
            worst = (np.max(np.abs(poles)) - 1 if self.discrete else
                     np.max(poles.real / np.maximum(np.abs(poles), 1e-300)))
            if worst < 0 and stable(z):
                found.append(z.copy())
                raise StopIteration
            return worst + 1e-3 * float(np.sum(((z - z0) / (upper - lower)) ** 2))

        try:
            optimize.minimize(instability, z0, method="Nelder-Mead", bounds=list(zip(lower, upper)),
                              options={"maxfev": RESTORATION_EVALUATIONS, "xatol": 1e-6,
                                       "fatol": 1e-9})
        except StopIteration:
            pass
        return found[0] if found else None

    def _x0(self, z0: np.ndarray) -> np.ndarray:
        """Start of every NLP variable: z0, and the extra variables where z0 puts them."""
        extra = np.asarray(self.extra_start(z0, self.param_values), dtype=float).ravel()
        extra = np.clip(np.nan_to_num(extra, nan=0.0, posinf=1e6, neginf=-1e6),
                        self.lbw[self.n_z:], self.ubw[self.n_z:])
        return np.concatenate([z0, extra])

    def _scale_at(self, z0: np.ndarray) -> float:
        """|objective| at the start, or the build-time scale where that is 0 or not finite."""
        value = self._evaluate(z0)[0]
        return abs(value) if value is not None and value != 0 else self.f_scale

    def _model_gap(self, seen, objective, bounds) -> float:
        """Largest relative gap between what the NLP saw and the exact numeric evaluation.

        Objective gaps are relative to the objective's scale, bound gaps to the bound.
        """
        seen_objective, seen_bounds = seen[0], seen[1]
        if objective is None or seen_objective is None:
            return math.inf
        gaps = [abs(seen_objective - objective) / max(abs(objective), 1e-9 * self.f_scale, 1e-300)]
        for a, b, bound in zip(seen_bounds, bounds, self.bounds):
            if a is None or b is None:
                return math.inf
            scale = max(abs(b), abs(bound.lower or 0), abs(bound.upper or 0), 1e-300)
            gaps.append(abs(a - b) / scale)
        return max(gaps)

    def _violation(self, bounds, conditions) -> float:
        total = float(np.sum(np.maximum(0.0, -conditions)))
        for value, b in zip(bounds, self.bounds):
            if value is None:
                return math.inf
            scale = max(1.0, abs(b.lower or 0), abs(b.upper or 0))
            if b.lower is not None:
                total += max(0.0, b.lower - value) / scale
            if b.upper is not None:
                total += max(0.0, value - b.upper) / scale
        return total

    @staticmethod
    def _better(key, best_key) -> bool:
        if key[0] != best_key[0]:
            return key[0] < best_key[0]
        a, b = key[1], best_key[1]
        if a is None or b is None:
            return b is None and a is not None
        return a < b - 1e-9 * max(1.0, abs(b))
