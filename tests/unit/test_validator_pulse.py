"""The validator's pulse generator (Tian's V-F transformation run plainly, period by period)
against Tian's closed forms and against the tuner's simulation with its short cuts
(feedtune/loops/pulse_train.py jumps over saturated runs and coasts to the next pulse): both must
give the same pulse train and the same errors, bit for bit (the same float operations in
the same order).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from feedtune.loops.pulse_train import PulseInput, simulate
from feedtune.validate import validate_result
from feedtune.validate.pulse_generator import PulseModel

DATA = Path(__file__).resolve().parents[1] / "data"


def model(amplitude=10.0, delta=1e-3, frequency=1e4, value=0.05, ratio=None, horizon=1.5):
    plant = {"type": "pulse_generator", "pulse_equivalent": delta, "input": "step",
             "amplitude": amplitude, "acceleration_law": ratio is not None}
    tuned = {"sampling_frequency": frequency, "error_limit": value}
    if ratio is not None:
        tuned["acceleration_ratio"] = ratio
    return PulseModel(plant, tuned, horizon)


def test_without_the_law_the_first_period_commands_delta_f_squared():
    """Tian eq 1: e jumps from 0 to value in one period, a = δ f²; the saturated run then
    sends one pulse per period, v_max = δ f; a step of N whole pulses ends on N exactly."""
    m = model()
    assert m.metric("peak_commanded_acceleration", {}) == pytest.approx(1e-3 * 1e4**2, rel=1e-12)
    assert m.metric("pulse_max_velocity", {}) == pytest.approx(1e-3 * 1e4, rel=1e-12)
    assert np.all(m.simulate()["pulses"][50:5000] == 1)  # saturated: a pulse every period
    assert m.simulate()["at_rest"] and m.counter()[-1] == 10_000
    assert m.metric("pulse_final_error", {}) == pytest.approx(0.0, abs=1e-12)
    assert m.stable()


@pytest.mark.parametrize("ratio", [10.0, 100.0])
def test_the_law_limits_the_acceleration_to_delta_f_squared_over_k(ratio):
    """Tian eq 2: |e_i − e_{i−1}| ≤ value/k, so |a| ≤ δ f²/k, reached while accelerating."""
    m = model(ratio=ratio)
    assert m.metric("peak_commanded_acceleration", {}) == pytest.approx(1e-3 * 1e4**2 / ratio,
                                                                        rel=1e-9)


@settings(max_examples=25, deadline=None)
@given(amplitude=st.floats(-3.0, 3.0), value_pulses=st.floats(1.0, 80.0),
       ratio=st.one_of(st.none(), st.floats(1.0, 500.0)))
def test_plain_run_equals_the_tuners_short_cut_simulation(amplitude, value_pulses, ratio):
    delta, frequency, horizon = 1e-3, 2e4, 0.4
    m = model(amplitude, delta, frequency, value_pulses * delta, ratio, horizon)
    theirs = simulate(delta, frequency, value_pulses * delta, ratio,
                      PulseInput("step", amplitude=amplitude), horizon)
    ours = m.simulate()
    assert ours["at_rest"] == theirs.at_rest
    assert np.array_equal(ours["pulses"], theirs.pulses)
    assert np.array_equal(ours["error"], theirs.error)


@settings(max_examples=40, deadline=None)
@given(value=st.floats(0.05, 5.0), ratio=st.floats(100.0, 5000.0),
       frequency=st.floats(5e4, 2e5), amplitude=st.sampled_from([10.0, -10.0, 2.5]))
def test_plain_run_equals_the_short_cuts_over_the_tian_example_box(value, ratio, frequency,
                                                                   amplitude):
    """Over the example's box (error limit 0.05–5 rad, k 100–5000, f 50–200 kHz, δ = 430/140 000
    rad): long law ramps, saturated runs and coasting to the next pulse, bit for bit the
    plain recursion (pulses, every e_i, the stop at rest), on the automatic horizon."""
    from feedtune.loops.pulse_train import automatic_horizon

    delta = 430.0 / 140e3
    command = PulseInput("step", amplitude=amplitude)
    horizon = automatic_horizon(delta, frequency, value, ratio, command)
    theirs = simulate(delta, frequency, value, ratio, command, horizon)
    ours = model(amplitude, delta, frequency, value, ratio, horizon).simulate()
    assert ours["at_rest"] == theirs.at_rest
    assert np.array_equal(ours["pulses"], theirs.pulses)
    assert np.array_equal(ours["error"], theirs.error)
    assert np.array_equal(ours["reference"], theirs.reference)


def test_tian_example_result_validates_exactly():
    result = json.loads((DATA / "tian-vf-pulse.result.json").read_text())
    block = validate_result(result)
    assert block["covered"] and block["ok"] is True
    rows = {e["metric"]: e for e in block["entries"]}
    assert set(rows) >= {"pulse_settling_time", "pulse_rise_time", "peak_commanded_acceleration",
                         "peak_measured_acceleration", "motor_acceleration_margin", "stable"}
    assert all(e["gap"] in (None, 0.0) for e in block["entries"])


def test_a_tampered_settling_time_is_caught():
    result = json.loads((DATA / "tian-vf-pulse.result.json").read_text())
    result["metrics"]["pulse_settling_time"]["value"] *= 1.001
    block = validate_result(result)
    assert block["ok"] is False
    assert not {e["metric"]: e for e in block["entries"]}["pulse_settling_time"]["ok"]
