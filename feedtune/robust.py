"""Robust tuning: the constraints hold for every value of the plant's uncertain numbers.

A spec may give some of the plant's numbers (:meth:`~feedtune.plants.base.Plant.numbers`)
as a set of values or a range (feedtune.schema.uncertainty). The NLP then holds one closed
loop per *scenario* (an assignment of the uncertain numbers), each built by the plant from
the same tunables with the scenario's numbers as NLP parameters, and puts every
constraint and the stability conditions on every loop; the objective is the nominal
plant's, or the worst scenario's (``robust.objective``, :mod:`feedtune.tuner.scenarios`).

The first solve's scenarios are the nominal plant, every corner (each combination of the
sets' values and the ranges' ends) and a few Latin-hypercube points inside the ranges. A
design that meets its constraints on finitely many scenarios may still break them between
them, so after each solve the ranges are searched for the numbers that violate each
constraint most (:func:`worst_cases`: a dense sample, then scipy's local refinement from the
worst sample), the worst of each violated constraint is added as a scenario and the NLP is
solved again from the previous optimum: the exchange method of semi-infinite programming,
as the tuner does for frequency grids. It stops when no constraint is violated anywhere
beyond :data:`ROBUST_TOL` of its bound, or after ``robust.max_rounds`` solves.

References
----------
R. Hettich, K. O. Kortanek, "Semi-infinite programming: theory, methods, and
applications", SIAM Review 35(3), 1993 (the exchange method).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Mapping

import casadi as ca
import numpy as np

from feedtune.expr import to_array, to_float
from feedtune.loops.loop import HorizonError
from feedtune.objectives import METRICS
from feedtune.plants import plant_for
from feedtune.schema.labels import metric_label
from feedtune.schema.result import (RobustResult, ScenarioResult, TuneResult, WorstCase,
                                    provenance)
from feedtune.schema.spec import Spec, parse_spec, tunable_box
from feedtune.schema.status import INFEASIBLE
from feedtune.schema.uncertainty import RobustSpec, corners
from feedtune.tuner import Bound, Term
from feedtune.tuner.stability import feasibility
from feedtune.tuner.terms import exact_value

#: a constraint holds over the uncertainty when no value of the numbers violates it by
#: more than this fraction of its bound (the bound is the constraint's physical scale:
#: M_peak ≤ 1.3 then holds to 1.3e-6, ζ ≥ 0.5 to 5e-7), the tuner's own feasibility
#: tolerance (feedtune.tuner.types.FEASIBILITY_TOL)
ROBUST_TOL = 1e-6
#: the interior samples' Latin hypercube is seeded, so a spec gives the same scenarios
INTERIOR_SEED = 20261127
#: the worst-case search's dense sample of the ranges: a grid of this many points per range
#: for one or two ranges, else a Latin hypercube of SEARCH_POINTS points
GRID_POINTS = {1: 41, 2: 15}
SEARCH_POINTS = 128
#: two scenarios are the same when every number agrees within this (relative)
SAME_POINT = 1e-9


@dataclass(frozen=True)
class Scenario:
    """One assignment of the uncertain numbers (name → value, each in its unit), where it
    came from (nominal, corner, interior, worst_case) and the round that added it."""

    values: Mapping[str, float]
    origin: str
    round: int = 1


def initial_scenarios(robust: RobustSpec, nominal: Mapping[str, float]) -> list[Scenario]:
    """The first solve's scenarios: the nominal numbers, every corner, and
    ``robust.interior_samples`` Latin-hypercube points inside the ranges (sets at their
    nominal value), without repeats."""
    scenarios = [Scenario(dict(nominal), "nominal")]
    for corner in corners(robust.parameters):
        _add(scenarios, Scenario(corner, "corner"))
    ranges = {name: p for name, p in robust.parameters.items() if p.is_range()}
    if ranges and robust.interior_samples:
        from scipy.stats import qmc  # only here: 0.3-0.5 s to import

        sample = qmc.LatinHypercube(d=len(ranges), seed=INTERIOR_SEED).random(
            robust.interior_samples)
        for row in sample:
            point = dict(nominal)
            point.update({name: p.min + u * (p.max - p.min)
                          for u, (name, p) in zip(row, ranges.items())})
            _add(scenarios, Scenario(point, "interior"))
    return scenarios


def _same(a: Mapping[str, float], b: Mapping[str, float]) -> bool:
    return all(abs(a[n] - b[n]) <= SAME_POINT * max(abs(a[n]), abs(b[n])) for n in a)


def _add(scenarios: list[Scenario], scenario: Scenario) -> bool:
    """Append ``scenario`` unless one with the same numbers is there; whether it was."""
    if any(_same(s.values, scenario.values) for s in scenarios):
        return False
    scenarios.append(scenario)
    return True


class ScenarioLoops:
    """What the tuner builds and evaluates when it asks for a loop: one loop per scenario
    (``loops[0]`` the nominal one). The tuner reads the stability and settling conditions
    and the matrices that must be stable of every scenario, and the objective terms,
    constraints and reports each read their own scenario's loop (:class:`ScenarioSet`)."""

    def __init__(self, loops: list):
        self.loops = loops
        self.exact_only = loops[0].exact_only
        if not self.exact_only:  # what the NLP reads (a search reads only stability())
            self.discrete = loops[0].discrete
            self.unrolled_steps = max(loop.unrolled_steps for loop in loops)

    def embedded_reads(self) -> frozenset[str] | None:
        """The embedded numbers any scenario's loop read (None when one does not record
        them; see :meth:`feedtune.loops.protocols.Loop.embedded_reads`)."""
        reads = [loop.embedded_reads() for loop in self.loops]
        return None if any(r is None for r in reads) else frozenset().union(*reads)

    def stability(self) -> dict:
        """An exact-only loop's verdict (the search reads it): the nominal loop's block,
        stable only when every scenario's loop is."""
        blocks = [loop.stability() for loop in self.loops]
        return {**blocks[0], "stable": all(block["stable"] for block in blocks)}

    def stability_conditions(self) -> list:
        return [c for loop in self.loops for c in loop.stability_conditions()]

    def settling_conditions(self) -> list:
        return [c for loop in self.loops for c in loop.settling_conditions()]

    def stability_matrices(self) -> dict:
        """The nominal loop's matrices by their names, each scenario's as
        ``scenario<k>.<name>``."""
        matrices = dict(self.loops[0].stability_matrices())
        for k, loop in enumerate(self.loops[1:], 1):
            matrices.update({f"scenario{k}.{name}": m
                             for name, m in loop.stability_matrices().items()})
        return matrices


class ScenarioSet:
    """The scenarios of one solve, as the tuner takes them: their numbers as NLP
    parameters (``scenario<k>.<name>``), a loop factory building every scenario's loop, and
    the objective terms, constraints and reports moved onto those loops."""

    def __init__(self, scenarios: list[Scenario], objective: str):
        self.scenarios = scenarios
        self.objective = objective

    def numbers(self) -> dict[str, float]:
        """Every scenario's uncertain numbers but the nominal one's, as NLP parameters."""
        return {f"scenario{k}.{name}": value for k, s in enumerate(self.scenarios[1:], 1)
                for name, value in s.values.items()}

    def key(self) -> list:
        """What the scenarios add to the structure key: their count, the uncertain names
        and the objective's form (their values are parameters)."""
        return [len(self.scenarios), sorted(self.scenarios[0].values), self.objective]

    def make_loop(self, build: Callable) -> Callable:
        """``values → ScenarioLoops``: ``build(values)`` for the nominal loop, and for each
        scenario with its numbers in place (the NLP's parameters when ``values`` holds them,
        else the scenario's own numbers)."""
        own_names = set(self.numbers())

        def make(values):
            own = {name: v for name, v in values.items() if name not in own_names}
            loops = [build(own)]
            for k, scenario in enumerate(self.scenarios[1:], 1):
                numbers = {name: values.get(f"scenario{k}.{name}", value)
                           for name, value in scenario.values.items()}
                loops.append(build({**own, **numbers}))
            return ScenarioLoops(loops)

        return make

    def terms(self, terms: list[Term]) -> list[Term]:
        """The objective: each term on the nominal loop, or (worst case) on every
        scenario's loop, one group per scenario."""
        count = len(self.scenarios) if self.objective == "worst_case" else 1
        return [Term(t.label, _on(t.value, k), t.weight, group=k)
                for k in range(count) for t in terms]

    def bounds(self, bounds: list[Bound]) -> list[Bound]:
        """Every constraint on every scenario's loop, the nominal ones first."""
        return [Bound(b.label if k == 0 else f"{b.label} in scenario {k}", _on(b.value, k),
                      b.lower, b.upper)
                for k in range(len(self.scenarios)) for b in bounds]

    @staticmethod
    def reports(reports: Mapping[str, Callable]) -> dict[str, Callable]:
        """Every report on the nominal loop."""
        return {key: _on(fn, 0) for key, fn in reports.items()}


def _on(fn: Callable, k: int) -> Callable:
    return lambda loops: fn(loops.loops[k])


# -- checking a tuned design over the uncertainty ------------------------------------------

def margin(value: float | None, lower: float | None, upper: float | None) -> float:
    """How far ``value`` is inside its bounds [the metric's unit]: negative outside, −∞
    when there is no value (an unstable loop, a response that cannot be computed); a value
    of +∞ (a gain margin without a phase crossover) is +∞ inside a lower bound and −∞
    outside an upper one."""
    if value is None or math.isnan(value):
        return -math.inf
    sides = [value - lower] if lower is not None else []
    sides += [upper - value] if upper is not None else []
    return min(sides)


def bound_scale(lower: float | None, upper: float | None) -> float:
    """The constraint's physical scale: the larger of its bounds' sizes (1 for a bound of
    0, where the metric's own unit is the scale)."""
    return max(abs(lower or 0.0), abs(upper or 0.0)) or 1.0


class PointCheck:
    """The spec's constraints and stability of the tuned design at any value of the
    uncertain numbers, on loops of numbers built by the plant (the tuner's own exact
    evaluation, not the NLP's grid).

    A point evaluated in full is remembered (``evaluations`` still counts every call): the
    result's scenario rows (:func:`_robust_result`) are points the last search evaluated."""

    def __init__(self, spec: Spec, tuned: Mapping[str, float]):
        self.plant = plant_for(spec.plant)
        self.box, _, _ = tunable_box(spec.tunables, self.plant.tunables())
        self.tuned = dict(tuned)
        self.constraints = [(METRICS[c.metric](), METRICS[c.metric].Options(**_options(c)),
                             c.min, c.max) for c in spec.constraints]
        self.evaluations = 0
        self._seen: dict[tuple, tuple[list[float | None], dict]] = {}

    def __call__(self, numbers: Mapping[str, float],
                 only: int | None = None) -> tuple[list[float | None], dict]:
        """(each constraint's value [its unit] or None, the stability block) at ``numbers``;
        with ``only``, that constraint's value alone (the others None)."""
        self.evaluations += 1
        key = tuple(sorted(numbers.items()))
        if only is None and key in self._seen:
            return self._seen[key]
        found = self._evaluate(numbers, only)
        if only is None:
            self._seen[key] = found
        return found

    def _evaluate(self, numbers: Mapping[str, float],
                  only: int | None) -> tuple[list[float | None], dict]:
        loop = self.plant.loop({**self.tuned, **numbers}, self.box)
        if loop.exact_only:  # a simulation: its verdict and metrics are numbers already
            stability = loop.stability()
            stable = stability["stable"]
        else:
            conditions = np.array([to_float(c) for c in loop.stability_conditions()])
            matrices = {name: to_array(m) for name, m in loop.stability_matrices().items()}
            stable, stability = feasibility([], [], conditions, matrices, loop.discrete)
        values = []
        for k, (metric, options, _, _) in enumerate(self.constraints):
            if only is not None and k != only:
                values.append(None)
                continue
            try:
                expr, magnitude = exact_value(metric.evaluate(loop, options))
                value = (float(expr) if loop.exact_only
                         else to_float(ca.evalf(ca.fabs(expr) if magnitude else expr)))
            except HorizonError:
                value = math.nan
            values.append(value if stable and not math.isnan(value) else None)
        return values, stability


def _options(constraint) -> dict:
    return constraint.model_dump(exclude={"metric", "min", "max"})


def _dense_unit(ranges: list[str]):
    """The dense sample of the ranges' unit box, (points × len(ranges)), and what it is in
    words: a grid over one or two ranges (:data:`GRID_POINTS`), a Latin hypercube over
    more."""
    if not ranges:
        return np.zeros((1, 0)), None
    if len(ranges) in GRID_POINTS:
        size = GRID_POINTS[len(ranges)]
        axis = np.linspace(0.0, 1.0, size)
        grid = f"{size}-point" if len(ranges) == 1 else f"{size} × {size}"
        return (np.array(np.meshgrid(*[axis] * len(ranges))).reshape(len(ranges), -1).T,
                f"a {grid} grid over {', '.join(ranges)}")
    from scipy.stats import qmc

    return (qmc.LatinHypercube(d=len(ranges), seed=INTERIOR_SEED + 1).random(SEARCH_POINTS),
            f"{SEARCH_POINTS} Latin-hypercube points over {', '.join(ranges)}")


def _search_points(robust: RobustSpec, nominal: Mapping[str, float]) -> list[dict[str, float]]:
    """The dense sample of the uncertainty: every combination of the sets' values with
    :func:`_dense_unit` over the ranges."""
    ranges = {name: p for name, p in robust.parameters.items() if p.is_range()}
    sets = {name: p for name, p in robust.parameters.items() if not p.is_range()}
    combos = corners(sets) if sets else [{}]
    unit, _ = _dense_unit(list(ranges))
    points = []
    for combo in combos:
        for row in unit:
            point = {**nominal, **combo}
            point.update({name: p.min + u * (p.max - p.min)
                          for u, (name, p) in zip(row, ranges.items())})
            points.append(point)
    return points


@dataclass
class Worst:
    """The worst value of one constraint over the uncertainty: where, its value, its margin
    [the metric's unit] and whether the margin is within ROBUST_TOL of the bound."""

    numbers: dict[str, float]
    value: float | None
    margin: float
    tolerance: float

    @property
    def holds(self) -> bool:
        return self.margin >= -self.tolerance


def worst_cases(check: PointCheck, robust: RobustSpec, nominal: Mapping[str, float],
                scenarios: list[Scenario]) -> tuple[list[Worst], dict[str, float] | None]:
    """Each constraint's worst case over the uncertainty, and the most unstable numbers
    found (None: stable everywhere sampled).

    Every point of :func:`_search_points` and every scenario is evaluated; from the point
    with the least margin of each constraint the ranges are refined locally with scipy
    (bounded Brent for one range, Nelder-Mead with bounds for more), the sets held at
    that point's values.
    """
    from scipy.optimize import minimize, minimize_scalar

    ranges = {name: p for name, p in robust.parameters.items() if p.is_range()}
    points = _search_points(robust, nominal) + [dict(s.values) for s in scenarios]
    table = [(point, *check(point)) for point in points]
    unstable = [(point, stability) for point, _, stability in table if not stability["stable"]]
    result = []
    for i, (_, _, lower, upper) in enumerate(check.constraints):
        scale = bound_scale(lower, upper)
        tolerance = ROBUST_TOL * scale
        point, values, _ = min(table, key=lambda row: margin(row[1][i], lower, upper))
        best = Worst(dict(point), values[i], margin(values[i], lower, upper), tolerance)
        if ranges and math.isfinite(best.margin):
            def at(u, point=point):
                numbers = {**point, **{name: p.min + x * (p.max - p.min)
                                       for x, (name, p) in zip(np.atleast_1d(u), ranges.items())}}
                value = check(numbers, only=i)[0][i]
                found = margin(value, lower, upper)
                if found < best.margin:
                    best.numbers, best.value, best.margin = numbers, value, found
                return found / scale if math.isfinite(found) else math.copysign(1e3, found)

            start = np.array([(point[name] - p.min) / (p.max - p.min)
                              for name, p in ranges.items()])
            if len(ranges) == 1:
                step = 1.0 / (GRID_POINTS[1] - 1)
                minimize_scalar(at, bounds=(max(0.0, start[0] - step), min(1.0, start[0] + step)),
                                method="bounded", options={"xatol": 1e-6})
            else:
                minimize(at, start, method="Nelder-Mead", bounds=[(0.0, 1.0)] * len(ranges),
                         options={"xatol": 1e-5, "fatol": 1e-9, "maxfev": 40 * len(ranges)})
        result.append(best)
    worst_unstable = None
    if unstable:
        worst_unstable = max(unstable, key=lambda row: row[1].get(
            "spectral_abscissa", row[1].get("spectral_radius", 0.0)))[0]
    return result, worst_unstable


def _search_text(robust: RobustSpec, points: int, evaluations: int) -> str:
    """How :func:`worst_cases` searched the uncertainty, for the result."""
    ranges = [name for name, p in robust.parameters.items() if p.is_range()]
    sets = any(not p.is_range() for p in robust.parameters.values())
    _, grid = _dense_unit(ranges)
    if grid is None:
        dense = "every combination of the sets' values"
    else:
        dense = grid + (" at every combination of the sets" if sets else "")
    local = ("" if not ranges else
             "; from each constraint's worst point, " + ("bounded Brent over the range"
                                                          if len(ranges) == 1 else
                                                          "Nelder-Mead within the box"))
    return (f"{dense} and every scenario ({points} points){local}; {evaluations} exact "
            "evaluations of the tuned design")


# -- the rounds ----------------------------------------------------------------------------

def tune_robust(spec: Spec, progress: Callable | None = None,
                notify: Callable[[str], None] | None = None) -> TuneResult:
    """Solve ``spec`` robustly over its uncertain numbers (see the module docstring); a
    failure is a result with ``success`` false, never an exception."""
    from feedtune.problem import _tune_once, _validation

    robust = spec.robust
    numbers = plant_for(spec.plant).numbers()
    nominal = {name: float(numbers[name]) for name in robust.parameters}
    scenarios = initial_scenarios(robust, nominal)
    round_spec, rounds, converged, note = spec, 0, False, ""
    result = worst = search = None
    unstable = None
    check = None
    while rounds < robust.max_rounds:
        rounds += 1
        check = None  # the check of this round's design, once it has one
        # not validated: every round's result is replaced by the last one, validated with
        # its scenarios and worst cases in _robust_result
        result = _tune_once(round_spec, progress, notify,
                            scenarios=ScenarioSet(list(scenarios), robust.objective),
                            validate=False)
        if not result.success:
            note = f"round {rounds}: the NLP over {len(scenarios)} scenarios did not solve"
            break
        tuned = {name: t.value for name, t in result.tuned.items()}
        check = PointCheck(spec, tuned)
        worst, unstable = worst_cases(check, robust, nominal, scenarios)
        search = _search_text(robust, len(_search_points(robust, nominal)) + len(scenarios),
                              check.evaluations)
        added = []
        if unstable is not None:
            added.append(("closed-loop stability", unstable))
        for constraint, case in zip(spec.constraints, worst):
            if not case.holds:
                added.append((metric_label(constraint.metric, _options(constraint)),
                              case.numbers))
        if not added:
            converged = True
            note = (f"robust: every constraint holds over the uncertainty within "
                    f"{ROBUST_TOL:g} of its bound after {rounds} round(s), "
                    f"{len(scenarios)} scenarios")
            break
        new = [label for label, numbers in added
               if _add(scenarios, Scenario(numbers, "worst_case", rounds + 1))]
        if not new:
            note = (f"robust: round {rounds}: the worst case of "
                    f"{', '.join(label for label, _ in added)} is a scenario the NLP already "
                    "holds (its exact value differs from the NLP's)")
            break
        if notify is not None:
            notify(f"robust: round {rounds}: {', '.join(new)} violated between the "
                   f"scenarios; solving again with {len(scenarios)} scenarios")
        round_spec = _from(spec, result)
    else:
        note = (f"robust: after {rounds} rounds ({len(scenarios)} scenarios) a constraint is "
                "still violated between the scenarios (robust.max_rounds)")
    return _robust_result(spec, result, scenarios, worst, unstable, rounds, converged, note,
                          _validation, search, check)


def _from(spec: Spec, result: TuneResult) -> Spec:
    """``spec`` started at ``result``'s tuned point with one start: the next round goes on
    from the previous optimum, as an exchange round does."""
    data = spec.model_dump(mode="json")
    tunables = data["tunables"]
    for name, tuned in result.tuned.items():
        if tuned.fixed:
            continue
        initial = min(max(tuned.value, tuned.min), tuned.max)
        tunables[name] = {"min": tuned.min, "max": tuned.max, "initial": initial}
    data["solver"]["multistart"] = 1
    return parse_spec(data)


def _robust_result(spec: Spec, result: TuneResult, scenarios: list[Scenario], worst, unstable,
                   rounds: int, converged: bool, note: str, validation: Callable,
                   search: str | None, check: PointCheck | None = None) -> TuneResult:
    """The last round's result as the spec's own: the spec and its hash, the nominal
    loop's stability block, the robust block; success only when converged. ``check``: the
    last search's :class:`PointCheck` of this result's design, whose scenario rows it
    has evaluated already."""
    tuned = {name: t.value for name, t in result.tuned.items()}
    if check is None and tuned:
        check = PointCheck(spec, tuned)
    scenario_results = []
    nominal_stability = result.stability
    for k, scenario in enumerate(scenarios):
        values, stability = check(scenario.values) if check else ([], {"stable": False})
        if k == 0:
            nominal_stability = stability
        holds = [margin(v, c.min, c.max) >= -ROBUST_TOL * bound_scale(c.min, c.max)
                 for v, c in zip(values, spec.constraints)]
        scenario_results.append(ScenarioResult(
            parameters=dict(scenario.values), origin=scenario.origin, round=scenario.round,
            stable=bool(stability["stable"]), constraints=values,
            satisfied=bool(stability["stable"]) and all(holds)))
    worst_results = [
        WorstCase(metric=c.metric, options=_options(c), min=c.min, max=c.max,
                  parameters=case.numbers, value=case.value,
                  margin=case.margin if case.margin > -math.inf else None,
                  tolerance=case.tolerance, satisfied=case.holds)
        for c, case in zip(spec.constraints, worst or [])]
    block = RobustResult(
        objective=spec.robust.objective, parameters=spec.robust.parameters,
        scenarios=scenario_results, worst_cases=worst_results, rounds=rounds,
        converged=converged, tolerance=ROBUST_TOL, search=search,
        unstable_parameters=dict(unstable) if unstable else None)
    success = result.success and converged
    data = {"spec": spec.model_dump(mode="json"), "provenance": provenance(spec.sha256()),
            "stability": nominal_stability, "robust": block, "success": success,
            "message": f"{result.message}; {note}" if note else result.message}
    if result.success and not converged:
        data["status"] = INFEASIBLE
    final = result.model_copy(update=data)
    return final.model_copy(update={"validation": validation(final)})
