"""feedtune.problem.Reports: every reported metric of a loop of numbers evaluated in one
CasADi Function gives, to the last bit, what evaluating each on its own gives."""

from __future__ import annotations

import json
from pathlib import Path

import casadi as ca
import pytest

from feedtune.problem import Reports, _report_sets, build_plant, resolve_tunables
from feedtune.schema.spec import parse_spec
from feedtune.tuner.terms import exact_value

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def _one_by_one(value) -> float:
    """A report's number as the tuner took it before: each expression on its own."""
    expr, magnitude = exact_value(value)
    return float(ca.fabs(ca.evalf(expr)) if magnitude else ca.evalf(expr))


def _setup(example: str):
    spec = parse_spec(json.loads((EXAMPLES / example).read_text()))
    plant = build_plant(spec)
    _, _, box = resolve_tunables(spec, plant)
    sets = _report_sets(spec, plant.loop({n: hi for n, (lo, hi) in box.items()}, box))
    return plant, box, sets


@pytest.mark.parametrize("example, point", [
    ("koren-1979-sampled-data.json", {"position_gain": 18.17, "sampling_period": 0.015625}),
    ("koren-1979-reference-pulse.json", {"position_gain": 25.25}),
    ("sato-finish.json", {"position_gain": 40.0, "sampling_period": 0.004,
                          "reference_interval": 0.02}),
])
def test_reports_evaluated_together_equal_each_on_its_own(example, point):
    plant, box, sets = _setup(example)
    fns = Reports(sets).callables()
    loop = plant.loop(point, box)
    together = {key: float(ca.evalf(fn(loop))) for key, fn in fns.items()}
    alone = {key: _one_by_one(metric.evaluate(plant.loop(point, box), options))
             for key, (metric, options) in sets.items()}
    assert together.keys() == alone.keys() and len(alone) > 10
    assert together == alone  # shared parts evaluated once, the same operations


def test_a_report_that_raises_raises_when_asked_and_the_others_still_evaluate(monkeypatch):
    plant, box, sets = _setup("koren-1979-sampled-data.json")
    metric, options = sets["damping_ratio"]

    def broken(loop, options):
        raise ZeroDivisionError("a metric's own failure")

    monkeypatch.setattr(metric, "evaluate", broken)
    fns = Reports(sets).callables()
    loop = plant.loop({"position_gain": 18.17, "sampling_period": 0.015625}, box)
    assert float(ca.evalf(fns["velocity_constant"](loop))) == pytest.approx(18.17, rel=1e-15)
    with pytest.raises(ZeroDivisionError):
        fns["damping_ratio"](loop)


def test_a_symbolic_loop_gets_the_expressions_themselves():
    plant, box, sets = _setup("koren-1979-sampled-data.json")
    gain = ca.MX.sym("gain")
    loop = plant.loop({"position_gain": gain, "sampling_period": 0.015625}, box)
    value = Reports(sets).callables()["velocity_constant"](loop)
    assert ca.depends_on(value, gain)


def test_a_term_on_a_loop_of_numbers_is_built_once_for_itself_and_its_report(monkeypatch):
    """Issue 15: the exact evaluation of a tuned design builds an objective term's or a
    constraint's expression once; the report of the same metric and options takes it."""
    from feedtune.objectives.contour.radial_error import RadialError
    from feedtune.problem import tune

    builds = []
    original = RadialError.evaluate

    def counted(self, loop, options):
        builds.append(loop)
        return original(self, loop, options)

    monkeypatch.setattr(RadialError, "evaluate", counted)
    spec = parse_spec(json.loads((EXAMPLES / "koren-1979-sampled-data.json").read_text()))
    result = tune(spec)
    assert result.success
    numeric = [loop for loop in builds if not ca.symvar(ca.MX(loop.gain))]
    assert len(numeric) == 1  # the objective term's; the report took it
    report = result.metrics["radial_error"].value
    assert report is not None and report == result.objective  # the same number, |e_r| [m]


def test_a_remembered_value_serves_only_its_own_loop_and_options():
    plant, box, sets = _setup("koren-1979-sampled-data.json")
    reports = Reports(sets)
    metric, options = sets["radial_error"]
    remember = reports.remembering(metric, options)
    other = options.model_copy(update={"radius": options.radius * 2})
    assert reports.remembering(metric, other) is None  # no report with these options
    point = {"position_gain": 18.17, "sampling_period": 0.015625}
    seen, loop = plant.loop(point, box), plant.loop(point, box)
    remember(seen, ca.MX(123.0))  # a stand-in: only the loop it was built on may take it
    fns = reports.callables()
    assert float(ca.evalf(fns["radial_error"](loop))) == pytest.approx(
        _one_by_one(metric.evaluate(plant.loop(point, box), options)), rel=0, abs=0)
    assert float(ca.evalf(fns["radial_error"](seen))) == 123.0


def test_the_default_option_variants_are_built_once_and_equal_a_fresh_build(monkeypatch):
    """Every metric's default options and their single-choice variants are the same for
    every spec: built once per options class (``_default_variants``), equal to a fresh
    ``_variants(Options())``, and the same objects in two specs' report sets."""
    import feedtune.problem as problem
    from feedtune.objectives import METRICS

    _, _, sampled = _setup("koren-1979-sampled-data.json")
    built = []
    monkeypatch.setattr(problem, "_variants", lambda default: built.append(default) or [default])
    _, _, pulse = _setup("koren-1979-reference-pulse.json")
    assert built == []  # nothing rebuilt for the second spec
    monkeypatch.undo()
    shared = [key for key in sampled if key in pulse and key in METRICS
              and problem._default_variants(METRICS[key].Options) is not None]
    assert len(shared) > 10
    for key in shared:
        assert sampled[key][1] is pulse[key][1]
        assert sampled[key][1] == problem._variants(METRICS[key].Options())[0]
    for cls in {type(metric) for metric, _ in sampled.values()}:
        try:
            fresh = problem._variants(cls.Options())
        except ValueError:  # options without defaults (a circle)
            fresh = None
        cached = problem._default_variants(cls.Options)
        assert (cached is None) if fresh is None else list(cached) == fresh
