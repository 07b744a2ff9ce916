"""From a spec to a result: picks the plant and metrics from the registries, hands the
tuner a loop factory and metric callables, and turns its outcome into a TuneResult."""

from __future__ import annotations

import functools
import json
import math
from typing import Callable, Literal, Mapping, get_args, get_origin

import casadi as ca

from feedtune.loops.loop import HorizonError
from feedtune.objectives import METRICS
from feedtune.plants import DATA_PLANTS, plant_for
from feedtune.plausibility import plausibility_warnings
from feedtune.schema.labels import metric_label
from feedtune.schema.result import (ConstraintResult, MetricValue, OptimumCheck, SolverResult,
                                    SpreadValue, StartResult, TunedValue, TuneResult, provenance)
from feedtune.schema.spec import Spec, SpecError, parse_spec, tunable_box
from feedtune.schema.status import ERROR
from feedtune.tuner import Bound, Settings, Term, Variable
from feedtune.tuner.cache import StructureKey
from feedtune.tuner.search import problem_class
from feedtune.tuner.terms import exact_value


#: the NLP's objective and constraints must match their exact evaluation this closely (relative)
MODEL_GAP_TOL = 1e-6
#: otherwise the step-response horizon grows by this factor and the problem is solved again
HORIZON_GROWTH = 4.0
MAX_HORIZON_REFINEMENTS = 2
#: starts at the same optimum are at different points when a tunable differs by more than
#: this (relative): IPOPT's tol 1e-9 puts a unique optimum's starts far closer than that
DISTINCT_POINT_TOL = 1e-3


def build_plant(spec: Spec):
    """The plant object named by ``spec.plant.type``."""
    return plant_for(spec.plant)


def resolve_tunables(spec: Spec, plant) -> tuple[list[Variable], dict[str, float], dict]:
    """Free variables, fixed values and the (min, max) box of every tunable
    (:func:`feedtune.schema.spec.tunable_box`)."""
    box, errors, _ = tunable_box(spec.tunables, plant.tunables())
    if errors:  # only for a Spec built without parse_spec, which refuses these
        raise SpecError(errors)
    variables, fixed = [], {}
    for name, (lower, upper) in box.items():
        if lower == upper:
            fixed[name] = lower
        else:
            given = spec.tunables.get(name)
            variables.append(Variable(name, lower, upper, given.initial if given else None))
    return variables, fixed, box


def _options_dict(term) -> dict:
    return term.model_dump(exclude={"metric", "weight", "goal", "min", "max"})




class LiftedOptions:
    """Metric options offered to the tuner as NLP parameters, beside the plant's numbers.

    A metric names in ``lifted_options`` the options that enter its expression only through
    arithmetic (a circle's radius and feed: ω = feed/radius); as constants of the graph they
    would give every circle its own solver (feedtune.tuner.nlp, "Solver reuse"). Each such
    option of each objective term and constraint becomes a number ``PREFIX.OPTION``
    (``objective0.radius``) that the tuner lifts like a plant's; the loops the tuner builds
    with those parameters are remembered, and a term evaluated on one of them reads its
    options as the parameters. On any other loop (the exact evaluation of a tuned design)
    it reads the spec's numbers, so both evaluate the same expression at the same values.
    """

    def __init__(self):
        self.numbers: dict[str, float] = {}  # parameter name → the spec's value
        self._loops: dict[int, tuple[object, dict]] = {}  # id(loop) → (loop, parameters)

    def value_fn(self, prefix: str, metric, options,
                 remember: Callable | None = None) -> Callable:
        """``loop → metric.evaluate(loop, options)``, the lifted options as parameters on a
        loop built by :meth:`make_loop`.

        On any other loop (one of numbers: the exact evaluation of a tuned design) the value
        is also handed to ``remember(loop, value)`` (:meth:`Reports.remember`), so the
        report of the same metric and options takes it instead of building it again.
        """
        names = {field: f"{prefix}.{field}" for field in metric.lifted_options
                 if isinstance(getattr(options, field, None), (int, float))}
        self.numbers.update({name: float(getattr(options, field)) for field, name in names.items()})

        def evaluate(loop):
            _, parameters = self._loops.get(id(loop), (None, None))
            if parameters is None and remember is not None:
                value = metric.evaluate(loop, options)
                remember(loop, value)
                return value
            if parameters is None or not names:
                return metric.evaluate(loop, options)
            lifted = options.model_copy(update={f: parameters[n] for f, n in names.items()})
            return metric.evaluate(loop, lifted)

        return evaluate

    def make_loop(self, build: Callable, values: Mapping) -> object:
        """``build(plant_values)``, ``values`` (the tuner's, by name) without the lifted
        options, remembered with ``values`` when any of them is a lifted option."""
        own = {name: value for name, value in values.items() if name not in self.numbers}
        loop = build(own)
        if len(own) < len(values):
            self._loops[id(loop)] = (loop, values)  # the loop kept: its id stays its own
        return loop


def structure_key(spec: Spec, plant, box: Mapping[str, tuple[float, float]],
                  lifted: Mapping[str, float], horizon_scale: float,
                  scenarios: list | None = None) -> str:
    """A key equal for two specs whose NLPs are the same graph (feedtune.tuner.structure),
    from the spec alone, before anything is built.

    It holds everything of the spec except the numbers the NLP takes as parameters: the
    plant's :meth:`~feedtune.plants.base.Plant.numbers`, fixed tunables' values, lifted
    metric options (``lifted``: ``objective0.radius`` → value), the size of each weight and
    of each constraint's bounds. What those numbers shape besides arithmetic stays in it:
    the plant's :meth:`~feedtune.plants.base.Plant.structure` (horizon, frequency band) at
    ``box`` and ``horizon_scale``, each weight's and bound's sign, which bounds are given,
    which tunables are free, and the solver settings but the number of starts (which
    only moves the starts), and ``scenarios`` (:meth:`feedtune.robust.ScenarioSet.key`:
    how many loops, which numbers are uncertain, the objective's form).
    """
    def term_shape(prefix: str, term, sides: tuple[str, ...]) -> dict:
        data = term.model_dump(mode="json")
        for field in list(data):
            if f"{prefix}.{field}" in lifted:
                data[field] = "parameter"
            elif field in sides and data[field] is not None:
                data[field] = math.copysign(1.0, data[field]) if data[field] != 0 else 0.0
        return data

    shape = json.dumps({
        "plant": plant.structure(box, horizon_scale),
        "free": sorted(name for name, (lower, upper) in box.items() if lower != upper),
        "objective": [term_shape(f"objective{i}", t, ("weight",))
                      for i, t in enumerate(spec.objective)],
        "constraints": [term_shape(f"constraint{i}", c, ("min", "max"))
                        for i, c in enumerate(spec.constraints)],
        "solver": spec.solver.model_dump(mode="json", exclude={"multistart"}),
        **({"scenarios": scenarios} if scenarios is not None else {}),
    }, sort_keys=True)
    embedded = plant.embedded_numbers(box, horizon_scale)
    return StructureKey(shape, tuple((name, json.dumps(value))
                                     for name, value in sorted(embedded.items())))


def _report_fn(metric, options) -> Callable:
    def evaluate(loop):
        try:
            return metric.evaluate(loop, options)
        except HorizonError:  # a step response too long for this box: report null
            return ca.MX(math.nan)

    return evaluate


class Reports:
    """The reported metrics' callables, which evaluate all of them together on a loop of
    numbers.

    The tuner asks for each report of the tuned design in turn and evaluates each
    expression on its own; many share the loop's costly parts (the step-response fold
    behind IAE, ISE and ITAE and their natural-time variants, the characteristic
    polynomial behind ζ and ω_n). So the first request on a loop builds every report's
    expression and evaluates them all in one CasADi Function, shared parts once, and each
    callable returns its number (a Magnitude's absolute value). A report that raises, or
    a loop with free symbols, keeps the plain one-by-one evaluation.
    """

    def __init__(self, sets: dict[str, tuple]):
        self.sets = dict(sets)
        self.fns = {key: _report_fn(metric, options) for key, (metric, options) in sets.items()}
        self._loops: dict[int, tuple[object, dict]] = {}  # id(loop) → (loop, key → value)
        # the values objective terms and constraints built on the last loop they saw
        self._remembered: tuple[object, dict] = (None, {})

    def callables(self) -> dict[str, Callable]:
        """Report name → ``loop → value``, for the tuner."""
        return {key: functools.partial(self._value, key) for key in self.fns}

    def remembering(self, metric, options) -> Callable | None:
        """``remember(loop, value)`` for an objective term or constraint of ``metric`` with
        ``options``: its value on ``loop`` is the expression of the report with equal options
        (None when no report has them), which the evaluation together then takes instead of
        building it a second time (radial error ≈ 2 ms a build). Only the last loop's values
        are kept, so a search evaluating thousands of loops holds one."""
        key = next((key for key, (report_metric, report_options) in self.sets.items()
                    if report_metric.name == metric.name and report_options == options), None)
        if key is None:
            return None

        def remember(loop, value):
            if self._remembered[0] is not loop:
                self._remembered = (loop, {})
            self._remembered[1][key] = value

        return remember

    def _value(self, key: str, loop):
        if id(loop) not in self._loops:
            self._loops[id(loop)] = (loop, self._evaluate_all(loop))  # the loop kept: its id stays its own
        values = self._loops[id(loop)][1]
        return values[key] if key in values else self.fns[key](loop)

    def _evaluate_all(self, loop) -> dict:
        """Report name → its number as a DM, for every report whose expression builds.

        The expressions (MX graphs of the loop's numbers) are evaluated together in one
        Function; a value that is a number already (a replayed peak, crossing or radius)
        is kept as it is, not passed through that Function as a constant (the same
        number, ≈ 25 µs less a report)."""
        exprs, numbers = {}, {}
        remembered = self._remembered[1] if self._remembered[0] is loop else {}
        for key, fn in self.fns.items():
            try:
                value = remembered[key] if key in remembered else fn(loop)
            except Exception:  # noqa: BLE001 — raised again when the tuner asks for it
                continue
            expr, magnitude = exact_value(value)
            value = ca.fabs(expr) if magnitude else expr
            if isinstance(value, ca.MX):
                exprs[key] = value
            elif isinstance(value, ca.DM):  # a number already: no graph, and no copy
                numbers[key] = value  # (≈ 23 µs a DM copied)
            elif isinstance(value, (int, float)):
                numbers[key] = ca.DM(value)
        if exprs:
            try:
                reports = ca.Function("reports", [], list(exprs.values()))
            except RuntimeError as exc:  # symbols of a loop inside the NLP (CasADi finds them
                if "are free" in str(exc):  # while it builds: no second walk over the graphs)
                    return {}
                raise
            numbers.update(zip(exprs, reports.call([])))
        return {key: numbers[key] for key in self.fns if key in numbers}


def _variants(default) -> list:
    """``default`` and, for each option with a fixed set of choices, each other choice."""
    variants = [default]
    for field_name, info in type(default).model_fields.items():
        if get_origin(info.annotation) is Literal:
            variants += [default.model_copy(update={field_name: choice})
                         for choice in get_args(info.annotation)
                         if choice != getattr(default, field_name)]
    return variants


@functools.cache
def _default_variants(options_cls) -> tuple | None:
    """:func:`_variants` of ``options_cls()``, None when its options have no defaults (a
    circle). The same for every spec, so built once per options class: the options are
    frozen models, shared by every spec's report sets (34 a spec were rebuilt, ≈ 0.1 ms)."""
    try:
        return tuple(_variants(options_cls()))
    except ValueError:
        return None


def _report_sets(spec: Spec, probe_loop) -> dict[str, tuple]:
    """Every metric the loop supports: with default options, each single change of a
    choice option (e.g. ``input: ramp``), and each option set the spec uses.

    A metric whose options have no defaults (a circle) and that is reported only (so no
    term can name it) takes the option sets of the terms whose metrics share its options:
    the exact circle test runs on every circle the spec's paper-formula terms name.
    """
    sets: dict[str, tuple] = {}
    terms = list(spec.objective) + list(spec.constraints)
    for name, metric_cls in METRICS.items():
        metric = metric_cls()
        candidates = []
        borrows = False
        defaults = _default_variants(metric.Options)
        if defaults is not None:
            candidates += defaults
        else:  # options without defaults (a circle): only the spec's own
            borrows = (metric.supports(probe_loop)
                       and not metric.optimisable(probe_loop))
        for term in terms:
            if term.metric == name or (borrows and METRICS[term.metric].Options is metric.Options):
                candidates.append(metric.Options(**_options_dict(term)))
        unique = []
        for options in candidates:
            if options not in unique and metric.supports(probe_loop, options):
                unique.append(options)
        for i, options in enumerate(unique):
            key = name if i == 0 else metric_label(name, options.model_dump())
            sets[key] = (metric, options)
    return sets


def tune(spec: Spec, progress: Callable | None = None,
         notify: Callable[[str], None] | None = None) -> TuneResult:
    """Solve ``spec``; a failed solve is a result with ``success`` false, never an exception.

    A plant that asks for a whole-number ratio of its interpolator (``integer_ratio``) is
    solved as :func:`_tune_integer_ratio` describes; otherwise see :func:`_tune_once`.
    """
    if spec.plant.type in DATA_PLANTS:  # measured data: the convex technique, no Loop
        from feedtune.measured.datadriven_spec import tune_data_driven

        return tune_data_driven(spec)
    if spec.robust is not None:  # uncertain plant numbers: feedtune.robust's rounds
        from feedtune.robust import tune_robust  # it solves each round with _tune_once

        return tune_robust(spec, progress, notify)
    if getattr(spec.plant, "integer_ratio", False):
        return _tune_integer_ratio(spec, progress, notify)
    return _tune_once(spec, progress, notify)


def _tune_integer_ratio(spec: Spec, progress, notify) -> TuneResult:
    """q = T/Δt_p whole: solve with q continuous, then again with q fixed (a constraint
    ``interpolation_ratio`` min = max) at ⌊q⌋ and ⌈q⌉ (≥ 1); the feasible one with the
    lower objective is the result, whose spec is the one solved (the added constraint shows
    among its constraints) and whose message tells the story. Without a feasible relaxed
    optimum, the relaxed result is returned with a note."""
    relaxed = _tune_once(spec, progress, notify)
    ratio = relaxed.metrics.get("interpolation_ratio")
    if not relaxed.success or ratio is None or ratio.value is None:
        return relaxed.model_copy(update={
            "message": relaxed.message + "; integer_ratio: no relaxed optimum to round, q "
                                         "not made whole"})
    q = ratio.value
    wholes = sorted({max(1, math.floor(q + 1e-9)), max(1, math.ceil(q - 1e-9))})
    results = []
    for whole in wholes:
        if notify is not None:
            notify(f"integer_ratio: relaxed q = {q:.6g}; solving again with q = {whole}")
        data = spec.model_dump(mode="json")
        data["constraints"].append({"metric": "interpolation_ratio", "min": whole, "max": whole})
        results.append((whole, _tune_once(parse_spec(data), progress, notify)))
    feasible = [(whole, r) for whole, r in results if r.success and r.objective is not None]
    story = "; ".join(f"q = {whole}: {r.status}" + (f", objective {r.objective:.6g}"
                                                    if r.objective is not None else "")
                      for whole, r in results)
    if not feasible:
        return relaxed.model_copy(update={
            "success": False, "status": results[-1][1].status,
            "message": (f"integer_ratio: relaxed q = {q:.6g} (objective "
                        f"{relaxed.objective:.6g}), no whole q feasible ({story}); the relaxed "
                        "optimum is shown")})
    whole, best = min(feasible, key=lambda item: item[1].objective)
    return best.model_copy(update={
        "message": (f"{best.message}; integer_ratio: relaxed q = {q:.6g} (objective "
                    f"{relaxed.objective:.6g}), {story}; kept q = {whole}")})


def _tune_once(spec: Spec, progress: Callable | None = None,
               notify: Callable[[str], None] | None = None, scenarios=None,
               validate: bool = True) -> TuneResult:
    """Solve ``spec`` once; a failed solve is a result with ``success`` false.

    ``scenarios`` (a :class:`feedtune.robust.ScenarioSet`): the NLP holds one loop per
    scenario of the plant's uncertain numbers, every constraint on each.

    ``validate`` false: the result's ``validation`` is left None (a robust round, whose
    result :func:`feedtune.robust.tune_robust` validates once, with its scenarios, at the
    end).

    ``progress(start, total)`` is called after each multistart start (see
    :meth:`feedtune.tuner.Problem.solve`); ``notify(text)`` with a sentence for people when
    the problem is solved again with a longer step-response horizon.

    Raises
    ------
    SpecError
        When the tunables' bounds are empty (never for a spec from :func:`parse_spec`,
        which checks them, and the step-response sample limit, itself).
    """
    plant = build_plant(spec)
    variables, fixed, box = resolve_tunables(spec, plant)
    tunables = plant.tunables()

    probe_loop = plant.loop({name: hi for name, (lo, hi) in box.items()}, box)
    report_sets = _report_sets(spec, probe_loop)
    together = Reports(report_sets)
    reports = together.callables()
    lifted = LiftedOptions()

    def value_fn(prefix: str, term) -> Callable:
        metric = METRICS[term.metric]()
        return lifted.value_fn(prefix, metric, term, together.remembering(
            metric, metric.Options(**_options_dict(term))))

    objective = [Term(term.metric, value_fn(f"objective{i}", term),
                      term.weight if term.goal == "minimize" else -term.weight)
                 for i, term in enumerate(spec.objective)]
    constraints = [Bound(metric_label(c.metric, _options_dict(c)), value_fn(f"constraint{i}", c),
                         c.min, c.max)
                   for i, c in enumerate(spec.constraints)]
    plant_numbers = plant.numbers()
    robust_key = None
    if scenarios is not None:
        objective, constraints = scenarios.terms(objective), scenarios.bounds(constraints)
        reports = scenarios.reports(reports)
        plant_numbers = {**plant_numbers, **scenarios.numbers()}
        robust_key = scenarios.key()
    s = spec.solver
    try:
        settings = Settings(multistart=s.multistart, max_iter=s.max_iter, tol=s.tol,
                            time_limit=s.time_limit, expand=s.expand,
                            ipopt_options=s.ipopt_options)
        for refinement in range(MAX_HORIZON_REFINEMENTS + 1):
            scale = HORIZON_GROWTH**refinement

            def make_loop(values, scale=scale):  # tunables, plant numbers, lifted options
                return lifted.make_loop(
                    lambda own: plant.loop(own, box, horizon_scale=scale), values)

            if scenarios is not None:
                make_loop = scenarios.make_loop(make_loop)

            # an exact-only loop (a pulse simulation) is searched, not solved as an NLP
            try:
                problem = problem_class(probe_loop)(
                    variables, fixed, make_loop, objective, constraints, reports, settings,
                    numbers={**plant_numbers, **lifted.numbers},
                    structure_key=structure_key(spec, plant, box, lifted.numbers, scale,
                                                robust_key))
            except HorizonError as exc:
                if refinement == 0:
                    raise
                outcome.message += (f"; a {scale:g}x longer step-response horizon is over the "
                                    f"sample limit ({exc}): the result is the shorter horizon's")
                break
            outcome = problem.solve(progress)
            if not outcome.stability.get("stable"):
                break  # a longer horizon cannot make an unstable loop's step response settle
            if outcome.model_gap <= MODEL_GAP_TOL and not outcome.horizon_bound:
                break
            if notify is not None and refinement < MAX_HORIZON_REFINEMENTS:
                reason = ("the step-response horizon's settling bound limits the result"
                          if outcome.horizon_bound else
                          f"the NLP differs from the exact evaluation by {outcome.model_gap:.2g}")
                notify(f"{reason}: solving again with a {HORIZON_GROWTH * scale:g}x longer "
                       "step-response horizon")
        else:
            outcome.message += (f"; after {MAX_HORIZON_REFINEMENTS} longer step horizons the "
                                f"NLP still differs from the exact evaluation by "
                                f"{outcome.model_gap:.2g} (relative), or the optimum still lies "
                                f"on the horizon's settling bound")
    except Exception as exc:  # noqa: BLE001 — a failure is a result, never a traceback
        return _error_result(spec, f"{type(exc).__name__}: {exc}")

    tuned = {}
    for name, tunable in tunables.items():
        value = outcome.values[name]
        lower, upper = box[name]
        at_bound = None
        if name not in fixed:
            if value <= lower * (1 + 1e-6):
                at_bound = "min"
            elif value >= upper * (1 - 1e-6):
                at_bound = "max"
        tuned[name] = TunedValue(value=value, unit=tunable.unit, fixed=name in fixed,
                                 min=lower, max=upper, at_bound=at_bound)
    position_unit = plant.position_unit
    # an unstable loop has no steady state, response or margin: its objective, metrics and
    # constraint values mean nothing, so none is reported and no constraint is met
    stable = bool(outcome.stability.get("stable"))
    metrics = {key: MetricValue(metric=metric.name, value=outcome.reports[key] if stable else None,
                                unit=metric.unit_of(options, position_unit),
                                options=options.model_dump())
               for key, (metric, options) in report_sets.items()}
    constraint_results = [
        ConstraintResult(metric=c.metric, options=_options_dict(c), min=c.min, max=c.max,
                         value=value if stable else None, satisfied=ok and stable)
        for c, (_, value, ok) in zip(spec.constraints, outcome.constraints)]
    solver = SolverResult(
        method=outcome.method, return_status=outcome.return_status, message=outcome.message,
        iterations=outcome.iterations, solve_time=outcome.solve_time,
        build_time=outcome.build_time, evaluation_time=outcome.evaluation_time,
        model_gap=outcome.model_gap if math.isfinite(outcome.model_gap) else None,
        starts=[StartResult(**vars(start)) for start in outcome.starts])
    optimum = (optimum_check(outcome.equal_optima, outcome.flat_tunables, tunables)
               if outcome.success else None)
    result = TuneResult(
        name=spec.name, success=outcome.success, status=outcome.status, message=outcome.message,
        objective=outcome.objective if stable else None, tuned=tuned, metrics=metrics,
        constraints=constraint_results, stability=outcome.stability, solver=solver,
        provenance=provenance(spec.sha256()), spec=spec.model_dump(mode="json"),
        optimum=optimum, warnings=plausibility_warnings(spec, metrics))
    if not validate:
        return result
    return result.model_copy(update={"validation": _validation(result)})


def optimum_check(equal_optima: list[tuple[int, dict[str, float]]], flat: list[str] | None,
                  tunables) -> OptimumCheck:
    """Is the tuned point the only one with its objective? (see OptimumCheck)

    Two tests: ``flat``, the tunables along a flat direction of the NLP at the optimum
    (reduced Hessian, see feedtune.tuner.optimum; None when there was no NLP), and the starts
    that reached the best objective (``equal_optima``, the best first, with their free
    tunables): a tunable whose values among them differ by more than DISTINCT_POINT_TOL
    (relative) spreads.
    """
    starts = [i + 1 for i, _ in equal_optima]
    spread = {}
    for name in (equal_optima[0][1] if equal_optima else {}):
        values = [point[name] for _, point in equal_optima]
        if max(values) - min(values) > DISTINCT_POINT_TOL * max(values):
            spread[name] = SpreadValue(min=min(values), max=max(values), unit=tunables[name].unit)
    undecided = list(dict.fromkeys([*(flat or []), *spread]))
    if not undecided:
        checked = flat is not None or len(equal_optima) > 1
        return OptimumCheck(unique=True if checked else None, starts=starts)
    advice = (f"the objective does not decide {', '.join(undecided)}: add a secondary objective "
              f"term with a small weight that prefers one point (e.g. iae), or fix one of them "
              f"(\"tunables\": {{\"{undecided[0]}\": {{\"value\": ...}}}})")
    return OptimumCheck(unique=False, starts=starts, spread=spread, flat=flat or [],
                        advice=advice)


def _validation(result: TuneResult) -> dict:
    """The validation block (feedtune.validate); a validator failure is a block, never raised.
    (The result's ``validation`` field takes any dict: re-validating the whole result with
    the block, a second dump and a validation of every field, checked nothing more.)"""
    try:
        from feedtune.validate import validate_result

        return validate_result(result)
    except Exception as exc:  # noqa: BLE001 — validation never breaks a tuning
        return {"covered": False, "ok": None, "entries": [], "reason": "validator error",
                "error": f"{type(exc).__name__}: {exc}"}


def _error_result(spec: Spec, message: str) -> TuneResult:
    """The result of a tuning that failed before IPOPT could report a status."""
    return TuneResult(
        name=spec.name, success=False, status=ERROR, message=message, objective=None,
        tuned={}, metrics={}, constraints=[], stability={"stable": False},
        solver=SolverResult(return_status="not_run", message=message, iterations=0,
                            solve_time=0.0, build_time=0.0, evaluation_time=0.0, model_gap=None,
                            starts=[]),
        provenance=provenance(spec.sha256()), spec=spec.model_dump(mode="json"))
