"""Tian et al., "A New Method of Generating Pulse Series for Numerical Controller".

§4 simulation settings: a 10 rad step, f = 140 kHz, v_max = 430 rad/s (so δ = v_max/f =
3.0714 mrad per pulse), the motor's acceleration 140 krad/s², error limit = value = 1
(rad, see docs/tian.md), k = δf²/a_max = 430 (eqs 1–2).
"""

from __future__ import annotations

import copy

import numpy as np
import pytest

import feedtune.problem
from feedtune.objectives import METRICS
from feedtune.plants.pulse_generator import PulseGenerator, PulseGeneratorParams
from feedtune.tuner import Bound, Settings, Term, Variable
from feedtune.tuner.search import SearchProblem
from feedtune.validate.pulse_generator import PulseModel

from conftest import load_example, tune_dict

F = 140e3  # Hz
V_MAX = 430.0  # rad/s
DELTA = V_MAX / F  # rad/pulse
A_MOTOR = 140e3  # rad/s²
K = DELTA * F**2 / A_MOTOR  # eq 2: k = controller acceleration / motor acceleration


def tian_loop(law: bool = True, error_limit: float = 1.0, k: float = K, **overrides):
    params = dict(type="pulse_generator", pulse_equivalent=DELTA, amplitude=10.0,
                  acceleration_law=law, motor_characteristic=[[0, A_MOTOR], [F, A_MOTOR]])
    params.update(overrides)
    plant = PulseGenerator(PulseGeneratorParams(**params))
    return plant.loop({"error_limit": error_limit, "sampling_frequency": F, "acceleration_ratio": k})


def metric(name, loop, **options):
    cls = METRICS[name]
    return cls().evaluate(loop, cls.Options(**options))


def test_k_for_tians_settings():
    # eq 1: δf² = 430 rad/s × 140 kHz = 60.2 Mrad/s²; eq 2: k = 60.2e6/140e3 = 430
    assert DELTA * F**2 == pytest.approx(60.2e6, rel=1e-12)
    assert K == pytest.approx(430.0, rel=1e-12)


def test_eq1_unlimited_controller_accelerates_at_delta_f_squared():
    """Eq 1: without the law the velocity rises from 0 to v_max in one period. The
    commanded acceleration is computed exactly from e_i, so only rounding separates it from
    δf² (1e-9)."""
    loop = tian_loop(law=False)
    assert metric("peak_commanded_acceleration", loop) == pytest.approx(DELTA * F**2, rel=1e-9)
    assert loop.controller_acceleration == pytest.approx(DELTA * F**2, rel=1e-12)


def test_fig4_step_reaches_the_target_with_acceleration_within_the_motor():
    """§4, Fig 4: the step reaches 10 rad (to the nearest pulse, |error| ≤ δ/2), comes to
    rest, and the commanded acceleration never exceeds 140 krad/s² (eq 2 holds exactly, so
    1e-9 covers rounding only); velocity saturates at v_max = 430 rad/s."""
    loop = tian_loop()
    response = loop.response
    assert response.at_rest and loop.stability()["stable"]
    assert metric("pulse_final_error", loop) <= DELTA / 2
    assert metric("pulse_overshoot", loop) == 0.0
    assert metric("peak_commanded_acceleration", loop) <= A_MOTOR * (1 + 1e-9)
    assert metric("peak_commanded_acceleration", loop) == pytest.approx(A_MOTOR, rel=1e-9)
    assert metric("pulse_max_velocity", loop) == pytest.approx(V_MAX, rel=1e-12)
    assert metric("motor_acceleration_margin", loop) >= -1e-9
    # measured reproduction (docs/tian.md): settles in 37.19 ms, rise time 18.6 ms
    assert metric("pulse_settling_time", loop) == pytest.approx(0.03719, abs=2e-5)


def test_without_the_law_the_acceleration_exceeds_the_motor():
    loop = tian_loop(law=False)
    assert metric("peak_commanded_acceleration", loop) > 100 * A_MOTOR
    # counted on the pulse train over 1 ms: v_max/1 ms = 430 krad/s² > 140 krad/s²
    assert metric("peak_measured_acceleration", loop, window=1e-3) == pytest.approx(430e3, rel=1e-9)
    assert metric("motor_acceleration_margin", loop) < -100
    # it still reaches the target
    assert loop.response.at_rest and metric("pulse_final_error", loop) <= DELTA / 2


def test_value_in_pulses_would_not_settle():
    """docs/tian.md: read as 1 pulse (not 1 rad), value = 1 leaves the law's ramp no linear
    zone: the axis passes the target at full speed and oscillates for ever (±≈215 pulses
    = k/2), contradicting Fig 4's "high precision in positioning"."""
    loop = tian_loop(error_limit=DELTA)
    assert not loop.response.at_rest and not loop.stability()["stable"]
    assert metric("pulse_overshoot", loop) > 200


def test_shortcuts_are_exact():
    """The short cuts (saturated runs, coasting to the next pulse, the stop at rest) change
    nothing: the validator's plain recursion, period by period over 60 ms (8 400 periods,
    past the 5 206 to rest), gives the same pulse train and errors, bit for bit. Speed is
    measured in benchmarks/tian_speed.py, not here."""
    loop = tian_loop()
    response = loop.response
    plain = PulseModel({"type": "pulse_generator", "pulse_equivalent": DELTA, "input": "step",
                        "amplitude": 10.0, "acceleration_law": True},
                       {"sampling_frequency": F, "error_limit": 1.0, "acceleration_ratio": K},
                       horizon=0.06).simulate()
    assert plain["at_rest"] and response.at_rest
    np.testing.assert_array_equal(plain["pulses"], response.pulses)
    np.testing.assert_array_equal(plain["error"], response.error)


def _small_search(multistart=1):
    """A cut-down Tian problem (a 1 rad step) the search solves in about a second."""
    plant = PulseGenerator(PulseGeneratorParams(
        type="pulse_generator", pulse_equivalent=DELTA, amplitude=1.0,
        motor_characteristic=[[0, A_MOTOR], [F, A_MOTOR]]))
    fixed = {"sampling_frequency": F}
    variables = [Variable("error_limit", 0.05, 5.0, 1.0), Variable("acceleration_ratio", 100, 5000, 430)]
    cls = METRICS["pulse_settling_time"]
    margin = METRICS["motor_acceleration_margin"]
    objective = [Term("pulse_settling_time", lambda loop: cls().evaluate(loop, cls.Options()))]
    constraints = [Bound("motor_acceleration_margin", lambda loop: margin().evaluate(loop, None), 0.0, None)]
    problem = SearchProblem(variables, fixed, lambda values: plant.loop(values), objective,
                            constraints, {}, Settings(multistart=multistart, max_iter=15))
    return problem.solve()


def test_search_beats_tians_setting_within_the_motor():
    outcome = _small_search()
    start = tian_loop(amplitude=1.0)
    assert outcome.success and outcome.model_gap == 0.0
    assert outcome.constraints[0][1] >= 0  # margin, from the exact simulation
    assert outcome.objective < metric("pulse_settling_time", start)
    assert outcome.values["sampling_frequency"] == F


HAS_DISPATCH = "problem_class" in vars(feedtune.problem)


# needs the problem.py patch of the pulse-generator report (dispatch to tuner.search)
@pytest.mark.skipif(not HAS_DISPATCH, reason="feedtune.problem does not dispatch exact-only loops yet")
def test_example_tunes_through_the_spec(tuned_example):
    spec = copy.deepcopy(load_example("tian-vf-pulse"))
    spec["solver"] = {"multistart": 1, "max_iter": 8}
    result = tune_dict(spec)
    assert result.success, result.message
    assert result.constraints[0].satisfied
    assert result.metrics["pulse_settling_time"].value < 0.03719
    assert result.metrics["peak_commanded_acceleration"].unit == "rad/s²"
    assert result.solver.method == "differential_evolution"  # not IPOPT: a discrete simulation
    # a root of the signed radial error (one tunable, one |e|: feedtune.tuner.roots)
    assert tuned_example("koren-1979-reference-pulse").solver.method == "root"
