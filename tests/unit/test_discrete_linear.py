"""The user-defined plant ``linear`` given as a discrete model (``model.period``, issue 16
item 1): spec refusals with their pointers, the loop it builds against the sampled loop of
the same drive given in s, and Koren's sampled-data servo written as its zero-order-hold
equivalent tuning as the dedicated plant does."""

from __future__ import annotations

import copy
import json
import math
from pathlib import Path

import casadi as ca
import control
import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

import feedtune
from feedtune.loops.sampled_lti import SampledLTILoop
from feedtune.plants import plant_for
from feedtune.plants.linear import MIN_MODEL_PERIOD
from feedtune.schema.spec import SpecError, parse_spec
from feedtune_cli import run_cli

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
TAU = 0.02  # Koren's drive time constant [s] (examples/koren-1979-sampled-data.json)
PERIOD = 1 / 64  # Koren's T [s]
#: Koren's drive K/(s(1 + sτ)) per unit K, discretised by python-control (ZOH at T)
ZOH = control.c2d(control.tf([1.0], [TAU, 1.0, 0.0]), PERIOD, "zoh")
NUMERATOR = [float(c) for c in ZOH.num[0][0]]
DENOMINATOR = [float(c) for c in ZOH.den[0][0]]

#: Koren's design example (examples/koren-1979-sampled-data.json: minimum radial error on
#: the 8 mm circle at 40 mm/s, ζ ≥ 0.5) with the drive given as its discrete model
KOREN = json.loads((EXAMPLES / "koren-1979-sampled-data.json").read_text())
KOREN["solver"] = {"multistart": 1}
DISCRETE = {
    **KOREN, "name": "koren-as-discrete-model",
    "plant": {"type": "linear", "implementation": "sampled", "input_unit": "m/s",
              "output_unit": "m",
              "model": {"type": "transfer_function", "period": PERIOD,
                        "numerator": NUMERATOR, "denominator": DENOMINATOR}},
    "tunables": {"position_controller.kp": {"min": 1, "max": 200}},
}
#: the same drive given in s, sampled by the loop's own hold at the same T
CONTINUOUS = copy.deepcopy(DISCRETE)
CONTINUOUS["plant"]["model"] = {"type": "transfer_function", "numerator": [1.0],
                                "denominator": [TAU, 1.0, 0.0]}
CONTINUOUS["tunables"]["sampling_period"] = {"value": PERIOD}


def with_plant(base: dict = DISCRETE, model: dict | None = None, **plant) -> dict:
    spec = copy.deepcopy(base)
    spec["plant"].update(plant)
    spec["plant"]["model"].update(model or {})
    return spec


def refusals(spec: dict) -> dict:
    with pytest.raises(SpecError) as error:
        parse_spec(spec)
    return dict(error.value.errors)


def loop_of(spec: dict, gain: float) -> SampledLTILoop:
    plant = plant_for(parse_spec(spec).plant)
    box = {name: (t.min, t.max) for name, t in plant.tunables().items()}
    box.update({name: (t.get("min", t.get("value")), t.get("max", t.get("value")))
                for name, t in spec["tunables"].items()})
    values = {"position_controller.kp": gain}
    if "sampling_period" in box:
        values["sampling_period"] = PERIOD
    return plant.loop(values, box)


def response(pair) -> complex:
    return complex(*(float(ca.evalf(ca.MX(x))) for x in pair))


# -- the spec ------------------------------------------------------------------------------

def _without_sampling_period(spec):
    spec["tunables"].pop("sampling_period", None)
    return spec


@pytest.mark.parametrize("model, plant, tunables, pointer, words", [
    # improper, and proper but with a direct feedthrough (the position would answer its
    # command within the sample it is computed in)
    ({"numerator": [1.0, 0.0, 0.0, 1.0]}, {}, {}, "/plant/model/numerator", "improper"),
    ({"numerator": [1.0, 0.5, 0.1]}, {}, {}, "/plant/model/numerator", "strictly proper"),
    ({"type": "zpk", "zeros": [0.5], "poles": [1.0], "gain": 1.0, "numerator": None,
      "denominator": None}, {}, {}, "/plant/model/zeros", "strictly proper"),
    ({"type": "state_space", "a": [[1.0]], "b": [[1.0]], "c": [[1.0]], "d": [[0.5]],
      "numerator": None, "denominator": None}, {}, {}, "/plant/model/d", "strictly proper"),
    ({"denominator": []}, {}, {}, "/plant/model/denominator", "at least 1"),
    ({"numerator": [0.0, 0.0]}, {}, {}, "/plant/model/numerator", "zero"),
    ({"period": 0.0}, {}, {}, "/plant/model/period", "greater than or equal to 0.000000001"),
    ({"period": -PERIOD}, {}, {}, "/plant/model/period", "greater than or equal to 0.000000001"),
    ({"period": 2.2250738585072014e-308}, {}, {}, "/plant/model/period",
     "greater than or equal to 0.000000001"),
    # a discrete drive is closed by a sampled controller, reads a position, has no velocity
    ({}, {"implementation": "continuous"}, {}, "/plant/implementation", "sampled"),
    ({}, {"output_unit": "m/s"}, {}, "/plant/output_unit", "position"),
    ({}, {"velocity_controller": "pi"}, {}, "/plant/velocity_controller", "no velocity"),
    # dead time: whole samples, given once, never negative
    ({}, {"dead_time": 1.5 * PERIOD}, {}, "/plant/dead_time", "whole number of samples"),
    ({}, {"dead_time": -PERIOD}, {}, "/plant/dead_time", "greater than or equal to 0"),
    ({}, {"dead_time_samples": -1}, {}, "/plant/dead_time_samples",
     "greater than or equal to 0"),
    ({}, {"dead_time_samples": 1.5}, {}, "/plant/dead_time_samples", "integer"),
    ({}, {"dead_time": PERIOD, "dead_time_samples": 1}, {}, "/plant/dead_time_samples",
     "once"),
    # the period is the model's: not tunable, not another, not restated
    ({}, {}, {"sampling_period": {"min": 0.001, "max": 0.1}}, "/tunables/sampling_period",
     "fixed to it, not tunable"),
    ({}, {}, {"sampling_period": {"value": 0.01}}, "/tunables/sampling_period",
     "its own period"),
    ({}, {}, {"sampling_period": {"value": PERIOD}}, "/tunables/sampling_period",
     "leave sampling_period out"),
    # a drive without an integrator under a P position controller: type 0
    ({"denominator": [1.0, -1.2, 0.35]}, {"position_controller": "p"}, {},  # (z − .5)(z − .7)
     "/plant/position_controller", "type 0"),
])
def test_bad_discrete_spec_is_refused_at_its_field(model, plant, tunables, pointer, words):
    spec = with_plant(DISCRETE, {k: v for k, v in model.items() if v is not None}, **plant)
    for key in [k for k, v in model.items() if v is None]:
        del spec["plant"]["model"][key]
    spec["tunables"].update(tunables)
    messages = refusals(spec)
    assert pointer in messages, messages
    assert words in messages[pointer], messages[pointer]


_coefficients = st.lists(st.floats(min_value=-1e3, max_value=1e3, allow_nan=False), min_size=1,
                         max_size=5)


@settings(max_examples=150, deadline=None)
@given(numerator=_coefficients, denominator=_coefficients,
       period=st.floats(min_value=-1.0, max_value=1.0, allow_nan=False),
       controller=st.sampled_from(["p", "pi", "pid"]), samples=st.integers(-2, 3))
# a constant term that underflows when made monic (linalg.roots raised IndexError)
@example(numerator=[2.0, 5e-324], denominator=[1.0, 0.0, 0.0], period=1.0, controller="pi",
         samples=0)
def test_any_discrete_model_parses_or_is_refused_at_its_field(numerator, denominator, period,
                                                              controller, samples):
    """Spec parsing over random models in z: a spec, or errors whose pointers name fields of
    the spec; never another exception. What decides it is known in advance: a zero
    numerator or one not strictly proper (improper only, when the period itself is
    refused: the model is then not known to be in z), a zero leading denominator
    coefficient, a period below MIN_MODEL_PERIOD (1 ns) and a negative dead time are refused at their own field."""
    spec = with_plant(model={"numerator": numerator, "denominator": denominator,
                             "period": period},
                      position_controller=controller, dead_time_samples=samples)
    spec["constraints"] = []  # ζ of the pole pair: order-2 loops only
    trimmed = numerator[next((i for i, c in enumerate(numerator) if c), len(numerator)):]
    expected = set()
    in_z = period >= MIN_MODEL_PERIOD  # a period it accepts makes the model one in z
    if not in_z:
        expected.add("/plant/model/period")
    if denominator[0] == 0:
        expected.add("/plant/model/denominator")
    elif not trimmed or len(trimmed) > len(denominator) - in_z:  # strictly, in z
        expected.add("/plant/model/numerator")
    if samples < 0:
        expected.add("/plant/dead_time_samples")
    try:
        parse_spec(spec)
    except SpecError as error:
        pointers = {pointer for pointer, _ in error.errors}
        assert expected <= pointers, (expected, error.errors)
        assert all(p.startswith(("/plant/", "/tunables/", "/objective/")) for p in pointers)
    else:
        assert not expected


def test_non_finite_coefficients_are_refused():
    spec = with_plant(model={"numerator": [math.nan, 1.0]})
    assert "/plant/model/numerator/0" in refusals(spec)


def test_dead_time_samples_is_for_discrete_models_only():
    spec = _without_sampling_period(with_plant(CONTINUOUS, dead_time_samples=1))
    spec["tunables"]["sampling_period"] = {"value": PERIOD}
    messages = refusals(spec)
    assert "dead_time [s]" in messages["/plant/dead_time_samples"]


def test_step_integrals_are_refused_with_what_is_supported():
    """A discrete model gives the position at the samples only: IAE needs the motion
    between them, so it is refused naming the metrics this loop supports."""
    spec = with_plant()
    spec["objective"] = [{"metric": "iae", "weight": 1}]
    message = refusals(spec)["/objective/0/metric"]
    assert "not defined for this plant configuration" in message
    supported = message.split("supported here: ")[1].split(", ")
    assert {"radial_error", "m_peak", "phase_margin", "decay_rate"} <= set(supported)
    assert "iae" not in supported


def test_an_unstable_drive_is_accepted():
    """As a continuous drive may be unstable, so may a discrete one (a pole at z = 1.2):
    the tuner holds the closed loop stable."""
    spec = with_plant(model={"denominator": [1.0, -2.2, 1.2]})  # (z − 1)(z − 1.2)
    assert parse_spec(spec).plant.model.period == PERIOD


def test_the_period_is_the_models_not_a_tunable():
    plant = plant_for(parse_spec(DISCRETE).plant)
    assert "sampling_period" not in plant.tunables()
    loop = plant.loop({"position_controller.kp": 10.0}, {"position_controller.kp": (1, 200)})
    assert loop.period == loop.period_box[0] == loop.period_box[1] == PERIOD


def test_bad_discrete_spec_exits_2_from_the_cli(tmp_path):
    spec = with_plant(dead_time=0.5 * PERIOD)
    path, out = tmp_path / "spec.json", tmp_path / "result.json"
    path.write_text(json.dumps(spec))
    run = run_cli("tune", str(path), "-o", str(out), text=True)
    assert run.returncode == 2, run.stderr
    assert "/plant/dead_time" in run.stderr
    assert not out.exists()


# -- the loop ------------------------------------------------------------------------------

@pytest.mark.parametrize("form", ["transfer_function", "zpk", "state_space"])
@pytest.mark.parametrize("delays", [{}, {"computation_delay": 1, "dead_time_samples": 1},
                                    {"dead_time": 2 * PERIOD}])
def test_discrete_model_is_the_sampled_loop_of_the_drive_in_s(form, delays):
    """The drive given in z (each form) closes the same discrete loop as the drive in s
    sampled by the loop's exact ZOH: open, closed and error responses, the closed loop's
    poles and C_v agree. Compared against their own magnitude: c2d's coefficients and the
    engine's exponential are each exact to rounding, so 1e-9 leaves rounding only (a wrong
    delay or hold is off by far more)."""
    a = math.exp(-PERIOD / TAU)
    b1, b0 = NUMERATOR
    model = {"transfer_function": {},
             "zpk": {"type": "zpk", "zeros": [-b0 / b1], "poles": [1.0, a], "gain": b1},
             "state_space": {"type": "state_space", "a": [[1.0, TAU * (1 - a)], [0.0, a]],
                             "b": [[b1], [1 - a]], "c": [[1.0, 0.0]]}}[form]
    discrete = with_plant(DISCRETE, **delays)
    if form != "transfer_function":
        discrete["plant"]["model"] = {**model, "period": PERIOD}
    continuous = with_plant(CONTINUOUS, computation_delay=delays.get("computation_delay", 0),
                            dead_time=delays.get("dead_time", 0.0)
                            + delays.get("dead_time_samples", 0) * PERIOD)
    for spec in (discrete, continuous):
        spec["constraints"] = []  # ζ of the pole pair: order-2 loops only
    gain = 15.0
    z_loop, s_loop = loop_of(discrete, gain), loop_of(continuous, gain)
    for omega in (0.5, 5.0, 25.0, 100.0, 0.99 * math.pi / PERIOD):
        for name in ("open_loop_response", "frequency_response", "error_response",
                     "sensitivity_response"):
            got, expected = (response(getattr(loop, name)(omega)) for loop in (z_loop, s_loop))
            assert abs(got - expected) <= 1e-9 * max(abs(expected), 1.0), (name, omega)
    poles = [np.sort_complex(np.linalg.eigvals(np.array(ca.evalf(loop.state_matrix))))
             for loop in (z_loop, s_loop)]
    np.testing.assert_allclose(poles[0], poles[1], rtol=0, atol=1e-9)
    assert float(ca.evalf(z_loop.velocity_constant)) == pytest.approx(gain, rel=1e-9)


# -- tuning: agreement with Koren's dedicated plant ----------------------------------------

@pytest.fixture(scope="module")
def tuned():
    return {name: feedtune.tune(spec) for name, spec in
            (("dedicated", KOREN), ("discrete", DISCRETE), ("continuous", CONTINUOUS))}


def test_koren_as_discrete_model_tunes_as_the_dedicated_plant(tuned):
    """Koren 1979 eq 40 / the design example: minimum radial error on the 8 mm circle at
    T = 1/64 s, K = 18.17 1/s on the dedicated plant. The drive written as its ZOH
    equivalent (c2d) tunes to the same K: both searches locate the zero of the same radial
    error (a root, so Brent's resolution is its BRENT_XTOL, 1e-10 in ln K), and the two
    loops differ by the rounding of c2d's coefficients; 1e-9 of K (1.8e-8 1/s) is ten
    times the search's resolution (measured: 7e-15)."""
    k_dedicated = tuned["dedicated"].values["position_gain"]
    k_discrete = tuned["discrete"].values["position_controller.kp"]
    assert tuned["discrete"].success and tuned["dedicated"].success
    assert k_dedicated == pytest.approx(18.17, abs=0.01)
    assert k_discrete == pytest.approx(k_dedicated, rel=1e-9)


def test_discrete_model_reports_every_metric_of_the_sampled_loop_but_the_integrals(tuned):
    """The metrics of the same drive given in s and sampled (the general sampled loop),
    but IAE/ISE/ITAE, which need the motion between samples; every shared value as the
    dedicated plant's, to 1e-7 relative (the K above moves them by at most their slope
    times 1e-9; the frequency metrics are refined to rounding)."""
    discrete, continuous = tuned["discrete"].metrics, tuned["continuous"].metrics
    integrals = {name for name in continuous if name.split("(")[0] in ("iae", "ise", "itae")}
    assert set(discrete) == set(continuous) - integrals
    dedicated = tuned["dedicated"].metrics
    for name in set(discrete) & set(dedicated):
        if name == "radial_error":  # zero at the optimum: on the scale of the radius
            assert abs(discrete[name].value - dedicated[name].value) <= 1e-12 * 0.008
            continue
        assert discrete[name].value == pytest.approx(dedicated[name].value, rel=1e-7), name


def test_validator_measures_every_metric_of_a_discrete_model(tuned):
    """The validator's own model of the drive given in z
    (feedtune/validate/sampled_linear.py) re-measures every metric the result reports, each
    within its tolerance (tests/unit/test_validator_discrete_linear.py checks that model
    against the drive in s and python-control)."""
    result = json.loads(tuned["discrete"].to_json())
    block = result["validation"]
    assert block["covered"] is True and block["ok"] is True, block
    measured = {e["metric"] for e in block["entries"]}
    reported = {m["metric"] for m in result["metrics"].values() if m["value"] is not None}
    assert reported <= measured, reported - measured
