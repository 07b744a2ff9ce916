"""Which numbers of each bundled plant may be uncertain (feedtune.plants.*.numbers), and the
exit-2 errors, at the pointer where the spec wrote the form, for those that may not: a
value that would change the model's structure (Plant.uncertainty_problem) or a field that
is not a number of the loop (Plant.not_uncertain says why)."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest

from feedtune.plants import plant_for
from feedtune.schema.spec import SpecError, parse_spec
from feedtune.schema.uncertainty import with_numbers

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def example(name: str) -> dict:
    return json.loads((EXAMPLES / f"{name}.json").read_text())


def errors(spec: dict) -> list[tuple[str, str]]:
    with pytest.raises(SpecError) as exc:
        parse_spec(spec)
    return exc.value.errors


def test_ward_leonard_numbers_are_its_machine_constants_and_la_only_when_given():
    spec = example("ward-leonard-feed-drive")
    assert set(plant_for(parse_spec(spec).plant).numbers()) == {
        "generator_gain", "generator_field_resistance", "generator_field_inductance",
        "armature_resistance", "armature_inductance", "torque_constant",
        "back_emf_constant", "inertia", "viscous_damping"}
    spec["plant"]["armature_inductance"] = 0.0
    assert "armature_inductance" not in plant_for(parse_spec(spec).plant).numbers()


def test_ward_leonard_loop_of_numbers_equals_the_loop_of_the_spec_with_them():
    """A scenario's numbers in ``values`` build the loop the spec with those numbers builds
    (the same polynomials: App. B eqs 1-3 read them once)."""
    spec = parse_spec(example("ward-leonard-feed-drive"))
    plant = plant_for(spec.plant)
    values = {"position_gain": 50.0, "velocity_gain": 20.0,
              **{f"{loop}_compensator.{t}": v for loop in ("velocity", "position")
                 for t, v in (("tau1", 0.5), ("tau2", 0.2), ("tau12", 10.0))}}
    box = {name: (v, v) for name, v in values.items()}
    changed = {"inertia": 13.0, "armature_inductance": 0.25, "torque_constant": 0.52}
    other = plant_for(type(spec.plant).model_validate(
        with_numbers(spec.plant.model_dump(mode="json"), changed)))
    a = plant.loop({**values, **changed}, box)
    b = other.loop(values, box)
    assert a.open_numerator == b.open_numerator and a.open_denominator == b.open_denominator


def test_ward_leonard_armature_inductance_may_not_reach_zero():
    spec = example("ward-leonard-feed-drive")
    spec["plant"]["armature_inductance"] = {"min": 0.0, "max": 0.3, "nominal": 0.2}
    [(pointer, message)] = errors(spec)
    assert pointer == "/plant/armature_inductance" and "order drops" in message
    spec["plant"]["armature_inductance"] = 0.0
    spec["robust"] = {"parameters": {"armature_inductance": {"min": 0.0, "max": 0.1}}}
    [(pointer, message)] = errors(spec)
    assert pointer == "/robust/parameters/armature_inductance"
    assert "neglects the armature pole" in message


def test_linear_coefficient_forms_inside_the_model_move_to_dotted_names():
    spec = example("user-defined-drive")
    spec["plant"]["model"]["denominator"][2] = {"nominal": 6.0, "tolerance_percent": 30}
    spec["plant"]["dead_time"] = [2e-4, 3e-4]
    parsed = parse_spec(spec)
    assert parsed.plant.model.denominator[2] == 6.0
    assert parsed.robust.parameters["model.denominator.2"].min == pytest.approx(4.2)
    assert parsed.robust.parameters["dead_time"].values == [2e-4, 3e-4]
    assert parse_spec(parsed.model_dump(mode="json")) == parsed  # canonical round trip


@pytest.mark.parametrize("index, form, pointer, words", [
    # the s² and s terms of s²(…): an end zero sets the integrators (loop type)
    (3, {"min": -1, "max": 1, "nominal": 0}, "/plant/model/denominator/3", "not a number"),
    (2, {"nominal": 6.0, "tolerance_percent": 130}, "/plant/model/denominator/2/tolerance_percent",
     "percent"),
    (0, {"min": -1e-6, "max": 3e-6, "nominal": 2e-6}, "/plant/model/denominator/0",
     "degree"),
])
def test_linear_structural_coefficients_are_refused_at_their_place(index, form, pointer, words):
    spec = example("user-defined-drive")
    spec["plant"]["model"]["denominator"][index] = form
    [(found, message)] = errors(spec)
    assert found == pointer and words in message


def test_linear_zpk_gain_and_pair_parts_may_be_uncertain_but_not_reach_zero():
    spec = example("user-defined-drive")
    spec["plant"]["model"] = {"type": "zpk", "poles": [0, 0, [-1, {"min": 0.5, "max": 2,
                                                                     "nominal": 1}]],
                              "zeros": [], "gain": {"min": 1, "max": 3}}
    assert set(parse_spec(copy.deepcopy(spec)).robust.parameters) == {
        "model.poles.2.1", "model.gain"}
    spec["plant"]["model"]["gain"] = {"min": -1, "max": 3}
    spec["plant"]["model"]["poles"][2][1] = {"min": -0.5, "max": 2, "nominal": 1}
    assert dict(errors(spec)).keys() == {"/plant/model/gain", "/plant/model/poles/2/1"}


def test_linear_state_space_and_sampled_loops_say_why_they_cannot():
    spec = example("user-defined-drive")
    spec["plant"]["model"] = {"type": "state_space", "a": [[0, 1], [0, {"min": -3, "max": -1}]],
                              "b": [[0], [1]], "c": [[1, 0]]}
    [(pointer, message)] = errors(spec)
    assert pointer == "/plant/model/a/1/1" and "transfer_function or zpk" in message
    sampled = example("user-defined-sampled-drive")
    sampled["plant"]["dead_time"] = [sampled["plant"].get("dead_time", 0.0), 3e-4]
    [(pointer, message)] = errors(sampled)
    assert pointer == "/plant/dead_time" and "sampled loop discretises" in message


def test_pulse_generator_takes_its_pulse_equivalent_not_its_command_or_motor_table():
    spec = example("tian-vf-pulse")
    spec["plant"]["pulse_equivalent"] = [0.003, 0.004]
    assert parse_spec(copy.deepcopy(spec)).robust.parameters["pulse_equivalent"].values == [
        0.003, 0.004]
    spec = example("tian-vf-pulse")
    spec["plant"]["amplitude"] = {"min": 5, "max": 10}
    [(pointer, message)] = errors(spec)
    assert pointer == "/plant/amplitude" and "describes the command" in message
    spec = example("tian-vf-pulse")
    spec["plant"]["motor_characteristic"][1][1] = {"min": 1e5, "max": 2e5}
    [(pointer, message)] = errors(spec)
    assert pointer == "/plant/motor_characteristic/1/1" and "one spec per motor" in message
