"""One CasADi NLP per problem, solved by IPOPT from deterministic starting points.

The tuner sees only a loop factory and metric callables; it never names a plant or a
metric. Free tunables are optimised as their logarithms (every tunable is positive, and
gains and periods span decades). :class:`Problem` puts the pieces together, each in its
own module:

* feedtune.tuner.builder — the NLP's variables, parameters, rows, and the scales probed
  at the starts;
* feedtune.tuner.terms — objective terms and constraints (epigraphs for |e| and peaks);
* feedtune.tuner.supremum — peaks and crossings over frequency, by the exchange method;
* feedtune.tuner.evaluation — what the NLP sees at a point, by name;
* feedtune.tuner.stability — Hurwitz/Schur rows, the eigenvalue verdict, restoration;
* feedtune.tuner.starts — the multistart's starting points;
* feedtune.tuner.cache — the process-wide solver cache;
* feedtune.tuner.calls — its Functions and IPOPT called with numbers through their
  evaluation buffers;
* feedtune.tuner.optimum — whether the optimum is unique;
* feedtune.tuner.scalar, feedtune.tuner.roots — one free tunable without IPOPT: the
  scalar search, or a root of the signed e where the objective is one |e|; with several
  free tunables and one |e|, a start after the chosen one can no longer change (it
  reached |e| = 0) is solved by a root of e one tunable at a time where one is found;
* feedtune.tuner.types — what the tuner takes and returns.

Solver reuse: every number of a problem that does not shape its graph is an NLP
parameter, so the solver and the Functions of a problem are cached per process
(feedtune.tuner.cache) and a result is the same whether its solver is new or reused. A
problem without free tunables builds no solver and is not cached.
"""

from __future__ import annotations

import math
import time
from typing import Callable, Mapping, NamedTuple

import casadi as ca
import numpy as np

from feedtune.expr import to_array, to_float
from feedtune.schema.status import ERROR, INFEASIBLE, OPTIMAL
from feedtune.tuner.builder import NlpBuilder, scale
from feedtune.tuner.cache import cached_build, cached_structure, store_structure
from feedtune.tuner.calls import numeric
from feedtune.tuner.evaluation import Seen, smallest_magnitudes
from feedtune.tuner.optimum import Solution, equal_optima, flat_tunables
from feedtune.tuner.scenarios import objective_value, worst_group
from feedtune.tuner.roots import ErrorCheck, RootSearch
from feedtune.tuner.roots import applies as root_search_applies
from feedtune.tuner.roots import applies_along as root_search_applies_along
from feedtune.tuner.scalar import ScalarSearch
from feedtune.tuner.scalar import applies as scalar_search_applies
from feedtune.tuner.stability import (add_stability_rows, feasibility, holds,
                                      nan_where_unstable, restore)
from feedtune.tuner.starts import starting_points
from feedtune.tuner.structure import Structure, build_structure, leading_values
from feedtune.tuner.supremum import ExchangeGroup, add_exchange_points
from feedtune.tuner.terms import add_bound, add_term, exact_value
from feedtune.tuner.types import (SOLVED, STATUS, Bound, Outcome, Settings, StartOutcome, Term,
                                  Variable, finite, number, within)

#: a scaled settling condition below this at the optimum means the horizon limited it
SETTLING_ACTIVE = 1e-6
#: expand the NLP to SX (≈4x faster solves, slower build) up to this many unrolled loop steps
AUTO_EXPAND_STEPS = 250
#: an NLP with peaks or crossings over frequency (exchange groups) is left unexpanded when
#: its MX graph has at most this many nodes per constraint row: its frequency grids are then
#: whole-row vector nodes (feedtune.tuner.builder keeps a grid's rows as one vector, the
#: loop's coefficients one SX Function: feedtune.tuner.supremum.FrequencyFunction), which
#: the MX virtual machine evaluates as fast as their SX expansion, and nlpsol builds no
#: SX Jacobian (≈ 390 instructions a row, 7 directions through every grid point's Horner
#: evaluation). Measured (2026-11-27, load 5): examples/user-defined-pid-notch.json (0.71
#: nodes a row) nlpsol 0.20 → 0.04 s, its Jacobian 0.86 → 0.76 ms a call, the same 57
#: iterations and bandwidth; Bhatia's and Ward-Leonard's specs and their 24 variants
#: (0.7-1.0) the same 26 optima in 29.5 → 24.3 s of CPU; examples/user-defined-drive.json
#: (2.0 nodes a row; it has a dead time) warm 0.29 → 0.46 s unexpanded: expanded
WHOLE_ROWS_NODES_PER_ROW = 1.5
#: IPOPT options the tuner always sets, after the caller's: no output (stdout carries the
#: result), and no options file (IPOPT otherwise reads ./ipopt.opt, which may name a
#: library to load)
#: limited-memory Hessian: the BFGS pairs kept (IPOPT's default 6). Measured on the bundled
#: Ward-Leonard spec from its one start: 253 iterations to an unstable point with 6, the
#: optimum in 133 with 20; Bhatia's spec the same optimum either way (197 / 167)
LBFGS_HISTORY = 20
#: how IPOPT solves with the limited-memory Hessian: "extended" puts the update's 2 × history
#: columns into the augmented system and factors it once per iteration, where IPOPT's default
#: "sherman-morrison" back-solves the system for every column (40 MUMPS solves an
#: iteration). The same Newton steps up to rounding; measured on
#: examples/user-defined-pid-notch.json (546 rows, 57 iterations, the same optimum): IPOPT's
#: rounds 0.86 → 0.44 s CPU (benchmarks/README.md, user_drive_vs_scipy.py). Only in
#: warm-started rounds: in the first round too it sent Bhatia's gains with ζ_min, σ_min and
#: M_s bounds (tests/reference/test_new_metrics.py, one of three orders of the bounds) to
#: "infeasible" (measured at the merge, 2026-11-27)
LBFGS_AUG_SOLVER = "extended"
#: MUMPS's fill-reducing ordering for that system: 2 (approximate minimum fill) instead of
#: IPOPT's automatic choice (7), which costs more on an augmented system with the update's
#: dense columns; the same iterations on the user drive, IPOPT's rounds 0.53 → 0.31 s CPU
LBFGS_MUMPS_ORDERING = 2
#: a round that goes on from the previous one (a new exchange point, or the exact Hessian
#: after the limited-memory one) starts from its primal and dual point with a small barrier
#: parameter; from scratch (IPOPT's μ = 0.1, iterates pushed off every active bound) each
#: round wandered off the optimum it was given: measured on Ward-Leonard variant 01, rounds
#: of 61-186 iterations, each leaving the optimum and the last ending unstable
WARM_START_OPTIONS = {"warm_start_init_point": "yes", "mu_init": 1e-6,
                      "warm_start_bound_push": 1e-9, "warm_start_bound_frac": 1e-9,
                      "warm_start_slack_bound_push": 1e-9, "warm_start_slack_bound_frac": 1e-9,
                      "warm_start_mult_bound_push": 1e-9}
#: nlpsol options: the tuner reads no multipliers of the parameters, so CasADi builds no
#: gradient of the Lagrangian for them ("nlp_grad", 165k SX instructions on the bundled
#: Ward-Leonard spec, built with every solver and called after every round); measured on
#: that spec: the cold solver's construction 0.63-0.85 → 0.47-0.52 s CPU (load 13-15)
NO_PARAMETER_MULTIPLIERS = {"calc_lam_p": False, "no_nlp_grad": True}
#: two starts' objectives (or violations) within this [relative, absolute below 1] are tied:
#: a later start must beat the best by more (:meth:`Problem._better`, :meth:`Problem._settled`)
OBJECTIVE_TIE = 1e-9
#: rounds of line searches over every free tunable (:meth:`Problem._root_along`)
ALONG_ROUNDS = 2
FIXED_IPOPT_OPTIONS = {"print_level": 0, "sb": "yes", "option_file_name": "",
                       "output_file": "", "file_print_level": 0}


class _Run(NamedTuple):
    """What one start gave (:meth:`Problem._run_start`): its status, IPOPT's return
    status, objective, iterations and exchange points, whether its end point is feasible,
    that point z [ln tunable], the bound values and stability conditions there,
    (solver, :class:`~feedtune.tuner.optimum.Solution`) of its last IPOPT round (None
    without one), and the method that solved it."""

    status: str
    return_status: str
    objective: float | None
    iterations: int
    exchanged: int
    feasible: bool
    z: np.ndarray
    bounds: list
    conditions: np.ndarray
    solution: tuple | None
    method: str = "ipopt"


class Problem:
    """The NLP, built once (or taken from the caches); :meth:`solve` runs the multistart.

    ``make_loop(values)`` builds the loop from values by name: every tunable's, and any of
    ``numbers`` (name → value, e.g. a plant's time constant), which the NLP holds as
    parameters as it holds fixed tunables (the exact evaluation passes the tunables only).

    ``structure_key``: a key the caller computed from its spec, equal for problems whose
    graphs are equal (feedtune.tuner.structure); the symbolic part of the first problem
    under a key is kept and every later one only computes its own numbers. None: built
    here, and shared only through the solver cache.
    """

    def __init__(self, variables: list[Variable], fixed: Mapping[str, float],
                 make_loop: Callable, objective: list[Term], constraints: list[Bound],
                 reports: Mapping[str, Callable], settings: Settings,
                 numbers: Mapping[str, float] | None = None, structure_key: str | None = None):
        started = time.perf_counter()
        self.variables, self.fixed, self.settings = variables, dict(fixed), settings
        self.objective_terms, self.bounds = objective, constraints
        self.make_loop, self.reports = make_loop, dict(reports)
        self.has_nlp = bool(variables)
        self.n_z = len(variables)
        numbers = dict(numbers or {}) if self.has_nlp else {}
        key = structure_key if self.has_nlp else None
        structure = cached_structure(key)
        if structure is None:
            structure = (build_structure(variables, fixed, numbers, make_loop, objective,
                                         constraints) if self.has_nlp else
                         build_structure(variables, {}, {}, lambda values: make_loop(
                             {**values, **{name: ca.MX(v) for name, v in fixed.items()}}),
                             objective, constraints))
        builder = structure.builder(variables, leading_values(
            fixed if self.has_nlp else {}, numbers, objective))
        self.discrete = structure.discrete
        self.evaluator = structure.evaluator.with_weights([t.weight for t in objective])
        self.param_values = builder.param_values
        self.starts = starting_points(variables, settings.multistart)
        self._seen: dict[bytes, Seen] = {}  # what the NLP sees, by point (_seen_at)
        scales = smallest_magnitudes([self._seen_at(z0) for z0 in self.starts])
        self.f_scale = scale(scales.objective)
        groups: list[ExchangeGroup] = []
        shares = [add_term(builder, index, value, scan, weight, term.weight, reference, groups)
                  for index, (value, scan, weight, term, reference) in enumerate(
                      zip(structure.term_values, structure.term_scans, structure.weights,
                          objective, scales.terms))]
        f = worst_group(builder, shares, [t.group for t in objective], self.f_scale)
        for index, (value, scan, bound, reference) in enumerate(
                zip(structure.bound_values, structure.bound_scans, constraints, scales.bounds)):
            add_bound(builder, index, value, scan, bound, reference, groups)
        scaled_settling = add_stability_rows(builder, structure.stability, structure.settling,
                                             scales.stability, scales.settling)
        self.exchange_groups = groups
        self.param_values = builder.param_values
        self.lbw, self.ubw = builder.lbw, builder.ubw
        self.lbg, self.ubg = builder.lbg, builder.ubg
        self.slot_defaults = builder.slot_defaults
        self._scanned = builder.scanned_values  # the scans the extra variables start from
        self._restarted = np.array(builder.restarted, dtype=int)  # started afresh on resume
        given = settings.ipopt_options.get("hessian_approximation")
        # peaks and crossings over frequency: the limited-memory Hessian first (measured
        # faster), the exact one for a start it leaves unsolved, infeasible or unstable
        self.hessians = ([given] if given else
                         ["limited-memory", "exact"] if groups else ["exact"])
        self.matrix_names = list(structure.matrices)
        if structure.build is None:  # the first problem of this structure: its Functions
            structure.build = self._functions(structure, builder, f, scaled_settling, groups)
            store_structure(key, structure)
        self._structure = structure
        self._solvers: dict[tuple[str, bool], object] = {}  # (Hessian, warm) → nlpsol
        self._last_solver = None  # the solver of the last round run
        # one free tunable and nothing else to decide: a line search, no IPOPT solver built
        searched = settings.scalar_search and not settings.ipopt_options
        scalar = searched and scalar_search_applies(self)
        # one free tunable and one |e| minimised: a root of e per start, IPOPT (its solver
        # built when a start first needs it) for the starts the root search declines
        roots = searched and root_search_applies(self)
        # several free tunables and one |e|: a start after the chosen one can no longer
        # change (:meth:`_settled`) only says whether it reaches that optimum, e = 0, too:
        # solved by a root of e one tunable at a time (:meth:`_root_along`), where one is
        # found; IPOPT otherwise. The chosen start, and so the tuned point, stays IPOPT's
        self._along = searched and root_search_applies_along(self)
        self._lines = None  # its ErrorCheck (feedtune.tuner.roots), made by the first line
        entry = self._entry(self.hessians[0], with_solver=not (scalar or roots))
        # called with numbers through their evaluation buffers (feedtune.tuner.calls), which
        # hold their Functions weakly: kept here while this problem is
        self._entry_functions = entry.functions
        self.settling = numeric(entry.functions["settling"])
        self.extra_start = numeric(entry.functions["extra_start"])
        self._exchange_levels = numeric(entry.functions["exchange_levels"])
        self.stability_check = numeric(entry.functions["stability_check"])
        self.solver_reused = entry.reused
        self.scalar = ScalarSearch.for_problem(self) if scalar else None
        if self.scalar is not None and not self.scalar.solvable:
            # no feasible grid point (an equality constraint, a narrow feasible band, no
            # stable loop): IPOPT, with restoration, looks between the points
            self.scalar = None
        if self.scalar is not None:
            self.starts = self.scalar.start_points()
        self.roots = RootSearch.for_problem(self) if roots else None
        if self.roots is not None and not self.roots.solvable:
            self.roots = None  # no feasible grid point: IPOPT's restoration looks between
        self.build_time = time.perf_counter() - started

    def _functions(self, structure: Structure, builder: NlpBuilder, f, scaled_settling: list,
                   groups: list[ExchangeGroup]) -> tuple:
        """(Functions, key-only Functions, expand) of the NLP ``builder`` holds, whose
        objective is ``f``: what the solver cache keys on and every later problem of this
        structure uses."""
        z, p = builder.z, builder.p
        # the objective is divided by its value at each start (a parameter, so one build
        # serves every start); a start that is not stable is first moved to a stable point
        # nearby (restoration), where that value means something
        objective_scale = ca.MX.sym("objective_scale")
        if groups:  # peaks and crossings over frequency do not see an unstable loop
            f = nan_where_unstable(f, structure.stability)
        functions = {
            "nlp": ca.Function("nlp", [builder.w, ca.vertcat(objective_scale, *builder.slots, p)],
                               [f / objective_scale, builder.g],
                               ["x", "p"], ["f", "g"]),
            "settling": ca.Function("settling", [z, p], [ca.vertcat(ca.MX(0, 1), *scaled_settling)]),
            "extra_start": ca.Function("extra_start", [z, p, *builder.scanned],
                                       [ca.vertcat(ca.MX(0, 1), *builder.extra_start)]),
            # per exchange group: the level its refined peak or dip is checked against
            "exchange_levels": ca.Function("exchange_levels", [z, *builder.extra, p],
                                           [ca.vertcat(ca.MX(0, 1), *[g.level for g in groups])]),
            # conditions and matrices alone: what restoration evaluates hundreds of times
            "stability_check": ca.Function("stability_check", [z, p],
                                           [ca.vertcat(*structure.stability),
                                            *structure.matrices.values()]),
        }
        expand = self.settings.expand
        if expand is None:  # auto: where expansion pays for itself (see the constants)
            nlp = functions["nlp"]
            expand = (structure.unrolled_steps <= AUTO_EXPAND_STEPS and not (
                groups and nlp.n_instructions() <= WHOLE_ROWS_NODES_PER_ROW * nlp.size1_out(1)))
        return functions, {"check": structure.evaluator.function}, expand

    def _options(self, hessian: str, warm: bool) -> dict:
        """nlpsol options: IPOPT's with this Hessian approximation, warm-started or not."""
        history = ({"limited_memory_max_history": LBFGS_HISTORY,
                    "mumps_pivot_order": LBFGS_MUMPS_ORDERING,
                    **({"limited_memory_aug_solver": LBFGS_AUG_SOLVER} if warm else {})}
                   if hessian == "limited-memory" else {})
        return {
            "ipopt": {"max_iter": self.settings.max_iter, "tol": self.settings.tol,
                      "max_wall_time": self.settings.time_limit, **history,
                      **(WARM_START_OPTIONS if warm else {}),
                      **self.settings.ipopt_options, "hessian_approximation": hessian,
                      **FIXED_IPOPT_OPTIONS},
            "print_time": False, "show_eval_warnings": False,
            "error_on_fail": False, **NO_PARAMETER_MULTIPLIERS,
        }

    def _entry(self, hessian: str, with_solver: bool = True):
        """The cached build (Functions and IPOPT solver) with this Hessian approximation;
        a solver is built when a start first needs it (never for the scalar search)."""
        functions, key_extra, expand = self._structure.build
        options = self._options(hessian, False)
        with_solver = self.has_nlp and with_solver
        entry = cached_build(functions, key_extra, options, expand, with_solver,
                             self._structure.solver_key(options) if with_solver else None)
        self._solvers[hessian, False] = entry.solver
        return entry

    def _solver(self, hessian: str, warm: bool = False):
        """The IPOPT solver with this Hessian approximation; ``warm``: the one that goes on
        from a previous round's primal and dual point. The warm solver shares the cold
        one's (expanded) NLP and derivative Functions: building it anew cost as much as
        the cold one (2.8-3.8 s at load 10 on the Ward-Leonard spec, a quarter of its
        tuning), from them 0.01-0.15 s."""
        solver = self._solvers.get((hessian, warm))
        if solver is None and not warm:
            solver = self._entry(hessian).solver
        elif solver is None:
            cold = self._solver(hessian)
            solver = ca.nlpsol("feedtune", "ipopt", cold.oracle(),
                               {**self._options(hessian, True), "cache": cold.cache()})
            self._solvers[hessian, True] = solver
        return solver

    def _seen_at(self, z_value) -> Seen:
        """:class:`~feedtune.tuner.evaluation.Seen` at ``z_value``, evaluated once per point:
        a start is seen for the scales and again for its objective scale, an end point for
        its feasibility and again for the model gap (each a numeric scan of every peak and
        crossing, 25-45 ms on the Ward-Leonard spec)."""
        key = np.asarray(z_value, dtype=float).tobytes()
        seen = self._seen.get(key)
        if seen is None:
            seen = self._seen[key] = self.evaluator(z_value, self.param_values)
        return seen

    def _evaluate(self, z_value):
        """What the NLP sees at ``z_value``: objective, bound values, conditions, matrices
        (see :class:`~feedtune.tuner.evaluation.Seen`)."""
        seen = self._seen_at(z_value)
        return seen.objective, seen.bounds, seen.stability, seen.matrices

    def _evaluate_numeric(self, values: Mapping[str, float]):
        """Objective, bounds, conditions, matrices and reports on the loop built from numbers.

        A loop of numbers may size itself exactly (e.g. integrate a step response until it
        has settled), so these are the values a result reports.
        """
        loop = self.make_loop(dict(values))

        def value_of(value, read=number):  # ±∞ kept (an Unbounded value), NaN as None
            expr, mag = exact_value(value)
            if not isinstance(expr, (ca.DM, float, int)):  # a number is read as it is
                expr = ca.evalf(expr)
            return read(abs(float(expr)) if mag else expr)

        terms = [value_of(t.value(loop), finite) for t in self.objective_terms]
        objective = objective_value([t.weight for t in self.objective_terms], terms,
                                    [t.group for t in self.objective_terms])
        bounds = [value_of(b.value(loop)) for b in self.bounds]
        conditions = np.array([to_float(c) for c in loop.stability_conditions()])
        matrices = {name: to_array(m)
                    for name, m in loop.stability_matrices().items()}
        reports = {key: value_of(fn(loop)) for key, fn in self.reports.items()}
        return objective, bounds, conditions, matrices, reports

    def _feasible(self, bounds, conditions, matrices) -> tuple[bool, dict]:
        """See :func:`feedtune.tuner.stability.feasibility`."""
        return feasibility(bounds, self.bounds, conditions, matrices, self.discrete)

    def _holds(self, bounds, conditions, matrices) -> bool:
        """:meth:`_feasible`'s verdict alone (a start's end: the stability block is the
        tuned point's only)."""
        return holds(bounds, self.bounds, conditions, matrices.values(), self.discrete)

    def solve(self, progress: Callable[[StartOutcome, int], None] | None = None) -> Outcome:
        """Run every start; ``progress(start_outcome, total)`` is called after each."""
        starts: list[StartOutcome] = []
        best = None  # (key, index, z, return_status, status)
        optima = []  # (index, objective, z) of every start that solved feasibly
        solutions: dict[int, tuple] = {}  # each start's solver and last NLP round
        for index, z0 in enumerate(self.starts):
            started = time.perf_counter()
            run = self._run_start(z0, started, self._along and self._settled(best))
            if run.solution is not None:
                solutions[index] = run.solution
            status, return_status, objective = run.status, run.return_status, run.objective
            z_opt, feasible = run.z, run.feasible
            starts.append(StartOutcome(index, status, return_status, objective, run.iterations,
                                       time.perf_counter() - started, feasible, run.exchanged,
                                       run.method))
            if progress is not None:
                progress(starts[-1], len(self.starts))
            solved = status in SOLVED and feasible and objective is not None
            # an unsolved start is ranked by its violation (only then computed)
            key = ((0, objective, index) if solved else
                   (1, self._violation(run.bounds, run.conditions), index))
            if solved:
                optima.append((index, objective, z_opt))
            if best is None or self._better(key, best[0]):
                best = (key, index, z_opt, return_status, status)
        _, index, z_opt, return_status, status = best
        equal = equal_optima(optima, index, self.f_scale, self.variables)
        solver, solution = solutions.get(index, (None, None))
        if self.scalar is not None:
            flat = self.scalar.flat_tunables(z_opt, self.variables[0].name)
        elif starts[index].method == "root":
            flat = []  # a root of e with e' ≠ 0, or a constraint's crossing: a vertex of |e|
        else:
            flat = flat_tunables(solver, solution, self.variables) if solution else None
        started = time.perf_counter()
        values = {v.name: float(math.exp(z_opt[i])) for i, v in enumerate(self.variables)}
        values.update(self.fixed)
        objective, bounds, conditions, matrices, reports = self._evaluate_numeric(values)
        feasible, stability = self._feasible(bounds, conditions, matrices)
        model_gap = self._model_gap(self._evaluate(z_opt), objective, bounds)
        settling = self.settling(z_opt, self.param_values).ravel()
        horizon_bound = bool(np.any(settling < SETTLING_ACTIVE))
        evaluation_time = time.perf_counter() - started
        success = status in SOLVED and feasible and objective is not None
        if status in SOLVED and feasible and objective is None:
            status = ERROR
            message = ("the objective is not a finite number at the tuned point (an input far "
                       "outside the model's range, or an optimised metric that is infinite there "
                       "because its quantity does not exist: bound it with a constraint instead)")
        elif success:
            message = f"start {index + 1} of {len(starts)} gave the best feasible optimum"
        elif status in SOLVED:
            status = INFEASIBLE
            broken = [b.label for v, b in zip(bounds, self.bounds) if not within(v, b.lower, b.upper)]
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
            constraints=[(b, v, within(v, b.lower, b.upper)) for b, v in zip(self.bounds, bounds)],
            stability=stability, iterations=starts[index].iterations,
            solve_time=sum(s.solve_time for s in starts), build_time=self.build_time,
            evaluation_time=evaluation_time, model_gap=model_gap, horizon_bound=horizon_bound,
            starts=starts, equal_optima=equal if success else [],
            flat_tunables=flat if success else None,
            method=starts[index].method)

    def _run_start(self, z0: np.ndarray, started: float, along: bool = False) -> "_Run":
        """Every attempt of the start from ``z0`` (the scalar search, or IPOPT with each
        Hessian in turn until one ends solved and feasible), ``started`` its clock [s,
        perf_counter]; ``along``: first a root of e one tunable at a time
        (:meth:`_root_along`)."""
        iterations = exchanged = 0
        solution = None
        z_root, evaluations = None, 0
        if self.roots is not None:
            found = self.roots.solve_from(float(z0[0]))
            if found is not None:
                z_root, evaluations = np.array([found.z]), found.evaluations
        elif along:
            z_root, evaluations = self._root_along(z0)
        if z_root is not None:
            objective, bounds, conditions, matrices = self._evaluate(z_root)
            feasible = self._holds(bounds, conditions, matrices)
            if feasible:  # else IPOPT, as for a start the search declines
                return _Run(OPTIMAL, "Solve_Succeeded", objective, evaluations, 0, True,
                            z_root, bounds, conditions, None, "root")
        attempts = (["scalar"] if self.scalar is not None else
                    self.hessians if self.has_nlp else [None])
        resume = None  # where the previous attempt of this start ended, if stable there
        for hessian in attempts:
            if hessian == "scalar":
                z_opt, return_status, iterations, exchanged, _ = self.scalar.solve_from(
                    z0, started)
                status = STATUS.get(return_status, "error")
            elif hessian is not None:
                z_opt, return_status, its, exchanged, last = self._solve_from(
                    z0, started, hessian, resume)
                iterations += its
                solution = (self._last_solver, last)
                status = STATUS.get(return_status, "error")
            else:
                z_opt, return_status, status = z0, "No_Free_Tunables", OPTIMAL
            objective, bounds, conditions, matrices = self._evaluate(z_opt)
            feasible = self._holds(bounds, conditions, matrices)
            if (status in SOLVED and feasible) or return_status == "No_Stable_Start":
                break
            # the next Hessian goes on from a stable end point, with its exchange
            # points (measured: the limited-memory run stops near the optimum at its
            # iteration limit, or with a peak just over its bound); from an unstable
            # one it starts afresh
            resume = (self._last_state if hessian not in (None, "scalar")
                      and self._stable(z_opt) else None)
        if return_status == "No_Stable_Start":  # nothing was solved: no objective to show
            objective = None
        return _Run(status, return_status, objective, iterations, exchanged, feasible, z_opt,
                    bounds, conditions, solution,
                    "brent" if self.scalar is not None else "ipopt")

    def _root_along(self, z0: np.ndarray) -> tuple[np.ndarray | None, int]:
        """(a root of e reached from ``z0`` one free tunable at a time, or None; the
        evaluations of e it took): along each tunable in turn, the others held
        (:meth:`RootSearch.for_problem <feedtune.tuner.roots.RootSearch.for_problem>`), a
        line's end that is not a root (a bound of the box, or a constraint's crossing,
        where |e| is least on that line) the point the next line searches from, for
        :data:`ALONG_ROUNDS` rounds; a line searched already (the same tunable, the others
        held where they were) is not searched again."""
        z, evaluations = np.array(z0, dtype=float), 0
        searched: dict[int, bytes] = {}  # tunable → the other tunables' values its line held
        if self._lines is None:  # the check read as the lines' points, made once
            self._lines = ErrorCheck(self)
        for _ in range(ALONG_ROUNDS):
            for axis in range(self.n_z):
                line = np.delete(z, axis).tobytes()
                if searched.get(axis) == line:
                    continue
                searched[axis] = line
                search = RootSearch.for_problem(self, held=z, axis=axis, check=self._lines)
                found = search.solve_from(float(z[axis])) if search.solvable else None
                evaluations += search.evaluations  # its own grid's too
                if found is not None:
                    z = z.copy()
                    z[axis] = found.z
                    if not found.vertex:
                        return z, evaluations
        return None, evaluations

    def _solve_from(self, start: np.ndarray, started: float, hessian: str, resume=None) -> tuple:
        """One start: IPOPT (with this Hessian approximation), then exchange rounds while a
        refined peak or dip violates its bound, each going on from the previous round's
        primal and dual point (:data:`WARM_START_OPTIONS`).

        Returns the tunables' logarithms, IPOPT's last return status, the iterations of
        every round, the number of exchange points added and the last round's
        :class:`~feedtune.tuner.optimum.Solution` (None if none ran). A round that does not
        solve ends the start with its status; so do the start's time limit
        (``time_limit``), running out of exchange points, and a start that restoration
        cannot make stable.

        ``resume`` (a previous attempt's ``_last_state``: x, objective scale, exchange
        slots, row bounds, points used per group and multipliers) goes on from where that
        attempt ended instead of from ``start``.
        """
        duals = None  # (lam_g, lam_x) of the previous round: the next one is warm-started
        if resume is not None:
            x0, p_scale, slots, lbg, ubg, used = (np.array(resume[0]), resume[1],
                                                  resume[2].copy(), resume[3].copy(),
                                                  resume[4].copy(), list(resume[5]))
            duals = resume[6]
            iterations = 0
            if self._restarted.size and duals is None:  # from z again, as at a start
                restarted = self.n_z + self._restarted
                x0[restarted] = self._x0(x0[:self.n_z])[restarted]
        else:
            z0 = self._stable_start(start)
            if z0 is None:  # IPOPT from an unstable point only wanders (measured: Bhatia's showcase)
                return start, "No_Stable_Start", 0, 0, None
            slots = self.slot_defaults.copy()
            lbg, ubg = self.lbg.copy(), self.ubg.copy()
            used = [0] * len(self.exchange_groups)
            x0, p_scale, iterations = self._x0(z0), self._scale_at(z0), 0
        while True:
            p = np.concatenate([[p_scale], slots, self.param_values])
            solver = self._solver(hessian, warm=duals is not None)
            # through the solver's evaluation buffer (feedtune.tuner.calls): the same solve
            call = numeric(solver, check=False)  # a failed solve is its status: error_on_fail
            result = call.named(x0=x0, p=p, lbx=self.lbw, ubx=self.ubw, lbg=lbg, ubg=ubg,
                                **({} if duals is None else {"lam_g0": duals[0],
                                                             "lam_x0": duals[1]}))
            stats = call.stats()
            self._last_solver = solver
            # IPOPT leaves iter_count unset (garbage) when it stops before iterating
            iterations += min(max(int(stats.get("iter_count", 0)), 0), self.settings.max_iter)
            return_status = stats.get("return_status", "unknown")
            x0 = result["x"].ravel()
            solution = Solution(x0, p, result["lam_g"].ravel(), result["lam_x"].ravel(),
                                lbg.copy(), ubg.copy())
            # only a solved round's multipliers are worth going on from: at an iteration
            # limit they are an unconverged guess, and a small barrier parameter on top of it
            # leads IPOPT astray (measured on a Rosenbrock toy, tests/unit/test_tuner_terms.py)
            duals = ((solution.lam_g, solution.lam_x) if STATUS.get(return_status) in SOLVED
                     else None)
            self._last_state = (x0, p_scale, slots.copy(), lbg.copy(), ubg.copy(), list(used),
                                duals)
            if STATUS.get(return_status) not in SOLVED:
                break
            if not self.exchange_groups:  # no peak or crossing to refine: nothing to add
                break
            z = x0[:self.n_z]
            levels = self._exchange_levels(z, *x0[self.n_z:], self.param_values).ravel()
            violations = [group.violations(z, self.param_values, level)
                          for group, level in zip(self.exchange_groups, levels)]
            added = add_exchange_points(self.exchange_groups, violations, slots, lbg, ubg, used)
            if added is None:
                return_status = "Exchange_Points_Exhausted"
                break
            if not added:
                break
            if time.perf_counter() - started > self.settings.time_limit:
                return_status = "Maximum_WallTime_Exceeded"
                break
        return x0[:self.n_z], return_status, iterations, sum(used), solution

    def _stable(self, z: np.ndarray) -> bool:
        """Every stability condition and every matrix's poles hold at the log tunables z."""
        conditions, *matrices = self.stability_check(z, self.param_values)
        return holds([], [], conditions, matrices, self.discrete)

    def _stable_start(self, z0: np.ndarray) -> np.ndarray | None:
        """``z0`` if its loop is stable, else a stable point near it (see
        :func:`feedtune.tuner.stability.restore`), or None.

        A point already seen (every start is, for the scales: :meth:`_seen_at`) is judged
        on the conditions and matrices seen there, the same expressions in the NLP check's
        Function, so the same numbers without a second call."""
        def evaluate(z):
            seen = self._seen.get(np.asarray(z, dtype=float).tobytes())
            if seen is not None:
                return seen.stability, list(seen.matrices.values())
            conditions, *matrices = self.stability_check(z, self.param_values)
            return conditions.ravel(), matrices

        return restore(z0, evaluate, self.lbw[:self.n_z], self.ubw[:self.n_z], self.discrete)

    def _x0(self, z0: np.ndarray) -> np.ndarray:
        """Start of every NLP variable: z0, and the extra variables where z0 puts them."""
        extra = self.extra_start(z0, self.param_values,
                                 *self._scanned(z0, self.param_values)).ravel()
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
            if a is None or b is None or (math.isinf(a) or math.isinf(b)) and a != b:
                return math.inf
            if a == b:  # also two equal infinities (an Unbounded value's, seen alike)
                gaps.append(0.0)
                continue
            scale_ = max(abs(b), abs(bound.lower or 0), abs(bound.upper or 0), 1e-300)
            gaps.append(abs(a - b) / scale_)
        return max(gaps)

    def _violation(self, bounds, conditions) -> float:
        """Summed violation of the stability conditions and (relative) of the bounds."""
        total = float(np.sum(np.maximum(0.0, -conditions)))
        for value, b in zip(bounds, self.bounds):
            if value is None:
                return math.inf
            size = max(1.0, abs(b.lower or 0), abs(b.upper or 0))
            if b.lower is not None:
                total += max(0.0, b.lower - value) / size
            if b.upper is not None:
                total += max(0.0, value - b.upper) / size
        return total

    @staticmethod
    def _settled(best) -> bool:
        """No later start can be chosen over ``best`` (see :meth:`solve`): it solved
        feasibly with an objective within :meth:`_better`'s tie of 0, the floor of a
        magnitude minimised (weight > 0), so a later start is evidence of where the
        optimum lies only."""
        return best is not None and best[0][0] == 0 and best[0][1] <= OBJECTIVE_TIE

    @staticmethod
    def _better(key, best_key) -> bool:
        """Start ``key`` beats ``best_key``: solved before unsolved, then lower objective
        (or violation), by more than :data:`OBJECTIVE_TIE` relative (absolute below 1)."""
        if key[0] != best_key[0]:
            return key[0] < best_key[0]
        a, b = key[1], best_key[1]
        if a is None or b is None:
            return b is None and a is not None
        return a < b - OBJECTIVE_TIE * max(1.0, abs(b))
