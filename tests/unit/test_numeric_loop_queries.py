"""The questions `feedtune validate` asks a Loop without CasADi (issue 15) get the answers the
expressions give: ``order`` against the size of the built state matrix, and
``SampledLoop.symbolic_horizon_samples`` against ``horizon_samples`` of the loop the tuner
builds on symbols (HorizonError alike). Every bundled example's plant and a spread of plant
configurations, at both ends of the default box. ``Plant.checked_loop``, the loop the
spec's checks read, answers every metric's applicability as the built loop does."""

from __future__ import annotations

import json
from pathlib import Path

import casadi as ca
import pytest
from pydantic import ValidationError

from feedtune.lazy import Deferred
from feedtune.loops.loop import HorizonError
from feedtune.loops.protocols import Capability
from feedtune.loops.sampled_plants import SampledModelError
from feedtune.objectives import METRIC_PATHS, metric_class
from feedtune.plants import plant_for
from feedtune.schema.spec import _PLANT, PLANT_MODELS, tunable_box
from feedtune.schema.uncertainty import move_inline_forms

REPO = Path(__file__).resolve().parents[2]
#: each example's plant at its nominal numbers (an uncertain one's set or range moved out,
#: feedtune.schema.uncertainty)
EXAMPLE_PLANTS = {path.stem: move_inline_forms(json.loads(path.read_text()), PLANT_MODELS)[0]["plant"]
                  for path in sorted((REPO / "examples").glob("*.json"))}
SERVO = {"type": "software_servo", "technique": "sampled_data", "time_constant": 0.05,
         "blu": 1e-5, "max_velocity": 0.2}
HYDRAULIC = EXAMPLE_PLANTS["bhatia-1971-hydraulic"]
VARIANTS = {
    **{f"example {name}": plant for name, plant in EXAMPLE_PLANTS.items()},
    **{f"servo delay {d} {model}": {**SERVO, "computation_delay": d, "model": model}
       for d in (0, 1, 3) for model in ("exact", "pade")},
    "servo ideal drive delay 1": {**SERVO, "time_constant": None, "computation_delay": 1},
    "servo ideal drive pade": {**SERVO, "time_constant": None, "model": "pade"},
    "servo linear interpolation": {**SERVO, "interpolation": "linear", "computation_delay": 2},
    "servo reference pulse": {**SERVO, "technique": "reference_pulse"},
    **{f"hydraulic {v} / {p}": {**HYDRAULIC, "velocity_compensator": v,
                                "position_compensator": p}
       for v in ("none", "lag", "lag_lead") for p in ("none", "lag", "lag_lead")},
    "hydraulic armature mode": {**HYDRAULIC, "torque_motor_natural_frequency": 775.0},
}
#: tunable boxes: the plant's defaults, and a sampling period down to 10 µs (over the limit)
BOXES = {"default": {}, "fast sampling": {"sampling_period": {"min": 1e-5, "max": 1e-2}}}


def _plant(raw: dict):
    return plant_for(_PLANT.validate_python(raw, strict=True))


def _symbolic_loop(plant, box: dict):
    """The loop the tuner builds: every tunable and plant number a symbol."""
    values = {name: ca.MX.sym(name) for name in [*box, *plant.numbers()]}
    return plant.loop(values, box)


def _outcome(read):
    """What ``read()`` gives, or the HorizonError message it raises."""
    try:
        return read()
    except HorizonError as exc:
        return f"HorizonError: {exc}"


@pytest.mark.parametrize("box_name", BOXES)
@pytest.mark.parametrize("variant", VARIANTS)
def test_numeric_answers_equal_the_expressions(variant, box_name):
    plant = _plant(VARIANTS[variant])
    tunables = plant.tunables()
    raw_box = {name: bounds for name, bounds in BOXES[box_name].items() if name in tunables}
    box, errors, complete = tunable_box(raw_box, tunables)
    assert not errors and complete
    try:
        symbolic = _symbolic_loop(plant, box)
    except SampledModelError as exc:
        # a dead time whose whole number of samples varies over the box: the spec refuses it
        # at its pointer (exit 2; tests/unit/test_sampled_linear.py)
        assert str(exc).startswith("/plant/dead_time:")
        return
    for end in (0, 1):  # validate builds its loop at the upper end of the box
        loop = plant.loop({name: bounds[end] for name, bounds in box.items()}, box)
        assert type(loop) is type(symbolic)
        if getattr(loop, "exact_only", False):
            assert loop.order == symbolic.order == 0  # a pulse simulation has no matrices
            continue
        assert loop.order == loop.state_matrix.shape[0] == symbolic.state_matrix.shape[0]
        if hasattr(type(loop), "horizon_samples"):
            assert ca.symvar(ca.vec(symbolic.state_matrix))  # the tuner's loop is symbolic
            assert (_outcome(lambda: loop.symbolic_horizon_samples)
                    == _outcome(lambda: symbolic.horizon_samples))


def test_some_variant_is_over_the_sample_limit():
    """The limit is exercised: a 10 µs sampling period needs more samples than allowed."""
    plant = _plant(SERVO)
    box, _, _ = tunable_box(BOXES["fast sampling"], plant.tunables())
    loop = plant.loop({name: hi for name, (lo, hi) in box.items()}, box)
    with pytest.raises(HorizonError):
        loop.symbolic_horizon_samples  # noqa: B018


def _default_options(metric):
    """The metric's options at their defaults, or None (as ``feedtune.schema.spec`` asks)."""
    try:
        return metric.Options()
    except ValidationError:
        return None


@pytest.mark.parametrize("box_name", BOXES)
@pytest.mark.parametrize("variant", VARIANTS)
def test_the_checked_loop_answers_as_the_loop_without_building_it(variant, box_name):
    """``Plant.checked_loop`` (what ``feedtune validate`` asks which metrics a plant
    supports, issue 15's start-up): every metric's ``supports`` and ``optimisable`` and every
    capability as on the loop the plant builds at the box's upper end; a deferred loop
    (Koren's reference pulse, whose matrices are CasADi's) answers them without being built,
    and every value it gives is the built loop's."""
    plant = _plant(VARIANTS[variant])
    tunables = plant.tunables()
    raw_box = {name: bounds for name, bounds in BOXES[box_name].items() if name in tunables}
    box, _, _ = tunable_box(raw_box, tunables)
    values = {name: hi for name, (lo, hi) in box.items()}
    try:
        built = plant.loop(values, box)
    except SampledModelError:
        return  # refused at its pointer (the test above)
    checked = plant.checked_loop(values, box)
    answers = {}
    for name in METRIC_PATHS:
        metric = metric_class(name)()
        options = _default_options(metric)
        answers[name] = [(metric.supports(loop, options),
                          metric.supports(loop, options) and metric.optimisable(loop, options))
                         for loop in (checked, built)]
    offered = {capability: (checked.offers(capability), built.offers(capability))
               for capability in Capability}
    assert {name: len(set(both)) for name, both in answers.items()} == dict.fromkeys(answers, 1)
    assert {c: len(set(both)) for c, both in offered.items()} == dict.fromkeys(offered, 1)
    assert any(supported for (supported, _), _ in answers.values())
    if isinstance(checked, Deferred):
        given = {name: value for name, value in vars(checked).items() if name != "_build"}
        assert "_built" not in given  # nothing above built it
        assert given == {name: getattr(built, name) for name in given}
    assert (plant.params.type == "software_servo"
            and plant.params.technique == "reference_pulse") == isinstance(checked, Deferred)
