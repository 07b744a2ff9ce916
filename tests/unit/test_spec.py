"""Spec checks beyond the property tests: IPOPT's own option table, an objective term's
``goal`` (minimize/maximize), and the data Bhatia's hydraulic drive needs."""

import json
from pathlib import Path

import pytest

from feedtune.spec import SpecError, parse_spec

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "koren-1979-sampled-data.json"


@pytest.mark.parametrize("options, pointer, reason", [
    ({"bogus_option": 3}, "/solver/ipopt_options/bogus_option", "No such IPOPT option"),
    ({"max_iter": "abc"}, "/solver/ipopt_options/max_iter", "type mismatch"),
])
def test_ipopt_options_are_checked_by_ipopt_before_solving(options, pointer, reason):
    spec = json.loads(EXAMPLE.read_text())
    spec["solver"]["ipopt_options"] = options
    with pytest.raises(SpecError) as info:
        parse_spec(spec)
    assert info.value.errors[0][0] == pointer
    assert reason in info.value.errors[0][1]


def test_valid_ipopt_options_pass():
    spec = json.loads(EXAMPLE.read_text())
    spec["solver"]["ipopt_options"] = {"max_iter": 50, "mu_strategy": "adaptive"}
    assert parse_spec(spec).solver.ipopt_options["max_iter"] == 50


# -- objective goal ----------------------------------------------------------------------------

BHATIA = Path(__file__).resolve().parents[2] / "examples" / "bhatia-1971-hydraulic.json"


def _bhatia() -> dict:
    return json.loads(BHATIA.read_text())


def test_goal_maximize_parses_and_minimize_is_the_default():
    spec = parse_spec(_bhatia())
    assert spec.objective[0].metric == "bandwidth" and spec.objective[0].goal == "maximize"
    koren = parse_spec(json.loads(EXAMPLE.read_text()))
    assert all(term.goal == "minimize" for term in koren.objective)


def test_goal_is_part_of_the_canonical_hash():
    spec = _bhatia()
    maximize = parse_spec(spec).sha256()
    spec["objective"][0]["goal"] = "minimize"
    explicit = parse_spec(spec).sha256()
    assert explicit != maximize
    del spec["objective"][0]["goal"]
    assert parse_spec(spec).sha256() == explicit  # the default, spelled out or not


@pytest.mark.parametrize("value", ["maximise", "MAXIMIZE", "max", "", 1, None, True, ["maximize"]])
def test_bad_goal_names_the_field(value):
    spec = _bhatia()
    spec["objective"][0]["goal"] = value
    with pytest.raises(SpecError) as info:
        parse_spec(spec)
    assert [pointer for pointer, _ in info.value.errors] == ["/objective/0/goal"]
    assert "'minimize' or 'maximize'" in info.value.errors[0][1]


def test_goal_is_not_a_constraint_field():
    spec = _bhatia()
    spec["constraints"][2]["goal"] = "maximize"
    with pytest.raises(SpecError) as info:
        parse_spec(spec)
    assert info.value.errors == [("/constraints/2/goal", "Extra inputs are not permitted")]


@pytest.mark.parametrize("goal, bound, damping", [("minimize", "max", 0.5), ("maximize", "min", 2.5)])
def test_goal_maximize_maximizes(goal, bound, damping):
    """Koren's continuous loop, ζ = 1/(2√(Kτ)) (eq 9), K in [2, 50] 1/s, τ = 20 ms: the
    least damping is at K = 50 (ζ = 0.5), the most at K = 2 (ζ = 2.5). The result's
    objective is the weighted sum with maximised terms counted negatively."""
    from feedtune.problem import tune

    spec = parse_spec({
        "name": "goal", "plant": {"type": "software_servo", "technique": "reference_pulse",
                                  "time_constant": 0.02, "blu": 5e-6, "max_velocity": 0.04},
        "tunables": {"position_gain": {"min": 2, "max": 50}},
        "objective": [{"metric": "damping_ratio", "goal": goal, "weight": 3}],
        "solver": {"multistart": 2}})
    result = tune(spec)
    assert result.success
    assert result.tuned["position_gain"].at_bound == bound
    assert result.metrics["damping_ratio"].value == pytest.approx(damping, rel=1e-6)
    sign = 1 if goal == "minimize" else -1
    assert result.objective == pytest.approx(sign * 3 * damping, rel=1e-6)


# -- hydraulic_rotary data -------------------------------------------------------------------

HYDRAULIC_DATA = ("bulk_modulus", "total_volume", "inertia", "leakage_coefficient")


@pytest.mark.parametrize("removed, named", [
    # ω_n and ξ both given: the load-path data is optional
    (HYDRAULIC_DATA, None),
    # ξ given, ω_n computed from β_e, V_t, J_t
    (("hydraulic_natural_frequency", "bulk_modulus"), ["bulk_modulus"]),
    (("hydraulic_natural_frequency", "total_volume", "inertia"), ["total_volume", "inertia"]),
    # ω_n given, ξ computed: K_ce too
    (("hydraulic_damping", "leakage_coefficient"), ["leakage_coefficient"]),
    # nothing to compute either from
    (("hydraulic_natural_frequency", "hydraulic_damping") + HYDRAULIC_DATA, list(HYDRAULIC_DATA)),
])
def test_hydraulic_rotary_without_its_hydraulic_data(removed, named):
    """Bhatia's drive needs ω_n and ξ, given or computed (App. A2); a spec without either
    is an error at /plant naming every missing field, once, in one message."""
    spec = _bhatia()
    for field in removed:
        del spec["plant"][field]
    if named is None:
        assert parse_spec(spec).plant.hydraulic_natural_frequency == 75.0
        return
    with pytest.raises(SpecError) as info:
        parse_spec(spec)
    assert len(info.value.errors) == 1
    pointer, message = info.value.errors[0]
    assert pointer == "/plant"
    assert "hydraulic_natural_frequency" in message and "hydraulic_damping" in message
    listed = message.split("missing: ")[1].split(", ")
    assert listed == named


@pytest.mark.parametrize("field", ["torque_motor_gain", "torque_motor_time_constant", "flow_gain",
                                   "displacement"])
def test_hydraulic_rotary_required_fields_are_named(field):
    spec = _bhatia()
    del spec["plant"][field]
    with pytest.raises(SpecError) as info:
        parse_spec(spec)
    assert (f"/plant/{field}", "Field required") in info.value.errors


def test_hydraulic_rotary_unknown_compensator_kind_is_named():
    spec = _bhatia()
    spec["plant"]["velocity_compensator"] = "lead"
    with pytest.raises(SpecError) as info:
        parse_spec(spec)
    assert info.value.errors[0][0] == "/plant/velocity_compensator"
    assert "'none', 'lag' or 'lag_lead'" in info.value.errors[0][1]


def test_compensator_tunables_need_the_compensator():
    """velocity_compensator.tau1 exists only with a velocity compensator."""
    spec = _bhatia()
    spec["plant"]["velocity_compensator"] = "none"
    with pytest.raises(SpecError) as info:
        parse_spec(spec)
    pointers = [pointer for pointer, _ in info.value.errors]
    assert pointers == ["/tunables/velocity_compensator.tau1", "/tunables/velocity_compensator.tau2",
                        "/tunables/velocity_compensator.tau12"]
    assert "unknown tunable" in info.value.errors[0][1]
