"""A loop whose phase never reaches −180° has an infinite gain margin (issue 16, items 3
and 6): python-control's ``stability_margins`` gives gm = inf, and so must the metric on a
loop of numbers, the validator, the tuner's constraint (a bound from below held, one from
above not) and the result's JSON.

The loops: Koren's reference-pulse loop K/(s(1 + sτ)) (Koren 1979 eq 5, τ = 20 ms as his
example; phase −90° − atan(ωτ) > −180° at every ω) as the dedicated plant and as a
user-defined ``linear`` drive 1/(s(1 + sτ)) under a P controller. Before the fix the metric
read 1/|L| at the top of its band (> 1e5 here), a finite number that meant nothing, and the
validator left the value out.
"""

from __future__ import annotations

import json
import math

import casadi as ca
import control
import pytest
from pydantic import ValidationError

from feedtune.objectives import METRICS
from feedtune.plants import plant_for
from feedtune.problem import tune
from feedtune.schema.result import MetricValue, TuneResult
from feedtune.schema.spec import SpecError, parse_spec
from feedtune.tuner.terms import exact_value
from feedtune.validate.linear import LinearModel

TAU = 0.02  # [s], Koren's example
KOREN = {"type": "software_servo", "technique": "reference_pulse", "time_constant": TAU,
         "blu": 5e-6, "max_velocity": 0.04}
LINEAR = {"type": "linear", "input_unit": "m/s", "output_unit": "m", "position_controller": "p",
          "model": {"type": "transfer_function", "numerator": [1.0], "denominator": [TAU, 1.0, 0.0]}}
GAINS = [5.0, 25.25, 60.0]  # [1/s]: ζ = 1/(2√(Kτ)) from 1.58 to 0.46


def spec(plant: dict, objective: list, constraints: list, tunable: str) -> dict:
    return {"name": "no-phase-crossover", "plant": plant,
            "tunables": {tunable: {"min": 1, "max": 200}}, "objective": objective,
            "constraints": constraints, "solver": {"multistart": 2}}


def metric_value(plant: dict, tunable: str, gain: float) -> float:
    """The gain-margin metric's value on the loop of numbers at ``gain``."""
    built = plant_for(parse_spec(spec(plant, [{"metric": "m_peak"}], [], tunable)).plant)
    loop = built.loop({tunable: gain}, {tunable: (1.0, 200.0)})
    metric = METRICS["gain_margin"]()
    return float(ca.evalf(exact_value(metric.evaluate(loop, metric.Options()))[0]))


@pytest.mark.parametrize("gain", GAINS)
@pytest.mark.parametrize("plant, tunable", [(KOREN, "position_gain"),
                                            (LINEAR, "position_controller.kp")])
def test_metric_validator_and_python_control_give_infinity(plant, tunable, gain):
    assert control.stability_margins(control.tf([gain], [TAU, 1, 0]))[0] == math.inf
    assert metric_value(plant, tunable, gain) == math.inf
    if plant is LINEAR:  # the validator's own model of the user's drive (numpy/scipy)
        assert LinearModel(plant, {tunable: gain}).gain_margin() == math.inf


def test_a_phase_crossover_still_gives_a_finite_margin():
    """One more lag, 1/(s(1 + sτ)(1 + sτ/10)): arg L = −180° at ω = 1/√(τ·τ/10), where
    GM = (τ + τ/10)/(Kτ·τ/10) (the third-order closed form of
    tests/unit/test_frequency_metrics.py; 1e-9: both crossings are located to rounding)."""
    gain, tau2 = 25.0, TAU / 10
    plant = {**LINEAR, "model": {"type": "transfer_function", "numerator": [1.0],
                                 "denominator": [TAU * tau2, TAU + tau2, 1.0, 0.0]}}
    expected = (TAU + tau2) / (gain * TAU * tau2)
    assert metric_value(plant, "position_controller.kp", gain) == pytest.approx(expected, rel=1e-9)


@pytest.mark.parametrize("plant, tunable", [(KOREN, "position_gain"),
                                            (LINEAR, "position_controller.kp")])
def test_a_min_bound_holds_without_a_phase_crossover(plant, tunable):
    """max ω_b s.t. M_peak ≤ 1.1 and GM ≥ 2: the gain margin is +∞ at every K, so its bound
    holds (vacuously) and the optimum is the closed form without it, K = 1/(4ζ²τ) with
    1/(2ζ√(1 − ζ²)) = 1.1 (tests/unit/test_reference_pulse_frequency.py); 1e-6 relative:
    IPOPT's tolerance on the M_peak row moved through dK/dM_peak ≈ 40 1/s at K ≈ 40 1/s.
    The result carries the +∞ as "Infinity" in its JSON and reads it back as math.inf."""
    zeta = math.sqrt((1 - math.sqrt(1 - 1 / 1.1**2)) / 2)
    result = tune(parse_spec(spec(plant, [{"metric": "bandwidth", "goal": "maximize"}],
                                  [{"metric": "gain_margin", "min": 2},
                                   {"metric": "m_peak", "max": 1.1}], tunable)))
    assert result.success and result.status == "optimal"
    assert result.tuned[tunable].value == pytest.approx(1 / (4 * zeta**2 * TAU), rel=1e-6)
    held = result.constraints[0]
    assert held.value == math.inf and held.satisfied
    assert result.metrics["gain_margin"].value == math.inf
    data = json.loads(result.model_dump_json())
    assert data["constraints"][0]["value"] == "Infinity"
    assert data["metrics"]["gain_margin"]["value"] == "Infinity"
    assert TuneResult.model_validate(data).metrics["gain_margin"].value == math.inf
    entry = next(e for e in result.validation["entries"] if e["metric"] == "gain_margin")
    assert (entry["reported"], entry["validated"], entry["ok"]) == ("Infinity", "Infinity", True)
    assert result.validation["ok"] is True


def test_a_max_bound_cannot_hold_without_a_phase_crossover():
    """GM ≤ 10 asks for a finite margin: +∞ exceeds it at every K, so no start is feasible
    and the constraint is reported violated at its value +∞."""
    result = tune(parse_spec(spec(KOREN, [{"metric": "iae"}],
                                  [{"metric": "gain_margin", "max": 10}], "position_gain")))
    assert not result.success
    assert result.constraints[0].value == math.inf and not result.constraints[0].satisfied


@pytest.mark.parametrize("goal", ["maximize", "minimize"])
def test_an_objective_infinite_over_the_box_is_refused_at_its_pointer(goal):
    """Maximising a margin that is +∞ at every K has no optimum (nor has minimising one):
    the spec is refused where the term stands, naming why and what to do instead."""
    with pytest.raises(SpecError) as caught:
        parse_spec(spec(KOREN, [{"metric": "iae"}, {"metric": "gain_margin", "goal": goal}],
                        [], "position_gain"))
    (pointer, message), = caught.value.errors
    assert pointer == "/objective/1/metric"
    assert "+∞" in message and "no phase crossover" in message and "constraint" in message


def test_an_objective_with_a_phase_crossover_is_accepted():
    """The same term on a third-order drive (a phase crossover at every K) is a spec."""
    plant = {**LINEAR, "model": {"type": "transfer_function", "numerator": [1.0],
                                 "denominator": [TAU * TAU / 10, TAU * 1.1, 1.0, 0.0]}}
    parse_spec(spec(plant, [{"metric": "gain_margin", "goal": "maximize"}], [],
                    "position_controller.kp"))


def test_nan_is_not_a_value_and_the_schema_names_the_strings():
    """The result's number type takes ±∞ (the JSON strings read back as floats) but never
    NaN (null stands for undefined), and its JSON Schema lists the two strings."""
    def record(value):
        return {"metric": "gain_margin", "value": value, "unit": "1"}

    assert MetricValue.model_validate(record("Infinity")).value == math.inf
    assert MetricValue.model_validate(record("-Infinity")).value == -math.inf
    assert json.loads(MetricValue(**record(-math.inf)).model_dump_json())["value"] == "-Infinity"
    for nan in ("NaN", math.nan):
        with pytest.raises(ValidationError):
            MetricValue.model_validate(record(nan))
    assert '"enum": ["Infinity", "-Infinity"]' in json.dumps(TuneResult.model_json_schema())


def test_a_robust_min_bound_holds_in_every_scenario():
    """τ uncertain in [15, 25] ms: the gain margin is +∞ in every scenario and at the worst
    case, whose margin to the bound is +∞ (before, the robust check took +∞ for "no value",
    a margin of −∞: violated); the validator's scenario checks agree."""
    data = spec({**KOREN, "time_constant": {"min": 0.015, "max": 0.025}},
                [{"metric": "bandwidth", "goal": "maximize"}],
                [{"metric": "gain_margin", "min": 2}, {"metric": "m_peak", "max": 1.1}],
                "position_gain")
    result = tune(parse_spec({**data, "solver": {"multistart": 1}}))
    assert result.success
    assert all(s.constraints[0] == math.inf and s.satisfied for s in result.robust.scenarios)
    worst = result.robust.worst_cases[0]
    assert (worst.value, worst.margin, worst.satisfied) == (math.inf, math.inf, True)
    assert result.validation["ok"] is True
