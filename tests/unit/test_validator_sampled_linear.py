"""The validator's model of the sampled ``linear`` loop (feedtune/validate/sampled_linear.py)
against python-control, which builds the same digital loop its own way: ``control.c2d``
of the drive (ZOH) and of the controller (Tustin or backward Euler), the delays as z^{−k},
``control.feedback``, ``control.stability_margins`` and its frequency evaluation; against
scipy's continuous simulation for a fractional dead time; and on a tuned result of the
bundled sampled example (examples/user-defined-sampled-drive.json).

Tolerances: both sides evaluate the same rational functions of z in double precision, so
they differ by rounding amplified by the conditioning of zI − F. Measured on these cases:
L within 2e-10, H within 5.4e-9 (python-control's feed-forward, a transfer function times
a state-space system), the margins within 5e-9, M_peak and bandwidth within 7e-11. The
asserted 1e-8 (1e-7 for the margins, whose python-control values come from its
frequency-response fallback) is 10–100× below the validator's own tolerances (1e-6
relative, feedtune/validate/tolerances.py), so a disagreement that could pass a tuned
result cannot pass here.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import control
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from discrete_checks import control_peak_and_bandwidth
from feedtune.validate import sampled_frequency, validate_result
from feedtune.validate.linear import controller_block, drive_block
from feedtune.validate.model import NotCovered
from feedtune.validate.models import model_for
from feedtune.validate.sampled_linear import SampledLinearModel

DATA = Path(__file__).resolve().parents[1] / "data"
#: the contract's drive (tests/contract/contract_cases.py): 1/(s(0.01 s + 1)) [rad/V]
DRIVE = {"type": "transfer_function", "numerator": [1.0], "denominator": [0.01, 1.0, 0.0]}
PERIOD = 1e-3  # s
REL = 1e-8  # see the module docstring

#: (plant options, tuned values): a P position loop, with computation delay and whole-sample
#: dead time; a PI velocity loop under P, Tustin and backward Euler, with feed-forward
CASES = {
    "p": ({}, {"position_controller.kp": 30.0}),
    "p-delay1-dead2": ({"computation_delay": 1, "dead_time": 2 * PERIOD},
                       {"position_controller.kp": 20.0}),
    "pi-position": ({"position_controller": "pi"},
                    {"position_controller.kp": 20.0, "position_controller.ti": 0.2}),
    "cascade-tustin": ({"velocity_controller": "pi"},
                       {"position_controller.kp": 30.0, "velocity_controller.kp": 0.3,
                        "velocity_controller.ti": 0.02}),
    "cascade-backward-ff": ({"velocity_controller": "pi", "discretisation": "backward_euler",
                             "velocity_feedforward": 0.5, "computation_delay": 1},
                            {"position_controller.kp": 30.0, "velocity_controller.kp": 0.3,
                             "velocity_controller.ti": 0.02}),
}


def plant_of(options: dict) -> dict:
    return {"type": "linear", "model": DRIVE, "input_unit": "V", "output_unit": "rad",
            "implementation": "sampled", **options}


def model_of(case: str) -> SampledLinearModel:
    options, tuned = CASES[case]
    return SampledLinearModel(plant_of(options), {**tuned, "sampling_period": PERIOD})


def control_loops(case: str):
    """(L, H) of the case as python-control discrete state-space systems."""
    options, tuned = CASES[case]
    plant = plant_of(options)
    tuned = {**tuned, "sampling_period": PERIOD}
    method = {"tustin": "tustin", "backward_euler": "backward_diff"}[
        plant.get("discretisation", "tustin")]
    drive = drive_block(DRIVE)
    # outputs: position C x and velocity C A x (C B = 0)
    outputs = np.vstack([drive.c, drive.c @ drive.a])
    pd = control.c2d(control.ss(drive.a, drive.b, outputs, np.zeros((2, 1))), PERIOD, "zoh")
    lag = plant.get("computation_delay", 0) + round(plant.get("dead_time", 0.0) / PERIOD)
    delay = control.tf([1.0], [1.0] + [0.0] * lag, PERIOD)

    def law(loop):
        block = controller_block(loop, plant, tuned)
        continuous = control.ss(block.a, block.b, block.c, block.d)
        return control.c2d(continuous, PERIOD, method) if block.order else block.d[0, 0]

    if plant.get("velocity_controller", "none") == "none":
        open_loop = law("position") * delay * pd[0, 0]
        return open_loop, control.feedback(open_loop, 1)
    forward = pd * delay * law("velocity")  # v_ref → [y, v], velocity loop open
    inner = control.feedback(forward, control.ss([], [], [], [[0.0, 1.0]], PERIOD))[0, 0]
    kp = tuned["position_controller.kp"]
    rate = plant.get("velocity_feedforward", 0.0) / PERIOD
    reference = kp + rate * control.tf([1.0, -1.0], [1.0, 0.0], PERIOD)  # K_p + k_ff(1 − z⁻¹)/T
    open_loop = kp * inner
    return open_loop, reference * control.feedback(inner, kp)


def near(a: float, b: float, rel: float = REL) -> bool:
    return abs(a - b) <= rel * abs(b)


@pytest.mark.parametrize("case", sorted(CASES))
def test_frequency_responses_are_python_controls(case):
    model = model_of(case)
    open_loop, closed = control_loops(case)
    omega = np.geomspace(0.1, math.pi / PERIOD, 41)
    z = np.exp(1j * omega * PERIOD)
    lo, h = model.frequency_response(omega)
    np.testing.assert_allclose(lo, open_loop(z), rtol=REL)
    np.testing.assert_allclose(h, closed(z), rtol=REL)


@pytest.mark.parametrize("case", sorted(CASES))
def test_poles_are_python_controls(case):
    """The closed loop's nonzero z-poles (a buffer sample's z = 0 depends on the states)."""
    _, closed = control_loops(case)
    expected = control.poles(closed)
    expected = np.sort_complex(expected[np.abs(expected) > 1e-9])
    poles = model_of(case).poles()
    poles = np.sort_complex(poles[np.abs(poles) > 1e-9])
    # distinct poles of a well-conditioned loop: eigenvalue rounding ~1e-14, on the unit
    # circle's scale (as the validator's poles entry, POLE_TOLERANCE 1e-6)
    np.testing.assert_allclose(poles, expected, atol=1e-9)


@pytest.mark.parametrize("case", sorted(CASES))
def test_margins_are_python_controls(case):
    """Gain margin, phase margin and crossover by control.stability_margins, which finds
    the crossings of the discrete loop up to π/T on its own."""
    model = model_of(case)
    open_loop, _ = control_loops(case)
    gm, pm, _, wpc, wgc, _ = control.stability_margins(open_loop)
    # python-control falls back to its frequency-response method here: ~5e-9 relative
    assert near(sampled_frequency.gain_margin(model, model.loop_type()), gm, 1e-7)
    assert near(sampled_frequency.phase_margin(model), pm, 1e-7)
    assert near(sampled_frequency.crossover(model), wgc, 1e-7)


@pytest.mark.parametrize("case", sorted(CASES))
def test_peak_and_bandwidth_are_python_controls(case):
    model = model_of(case)
    _, closed = control_loops(case)
    peak, bandwidth = control_peak_and_bandwidth(closed, PERIOD)
    # both polish with Brent to xatol 1e-12 in ln ω: the peak agrees to rounding, the
    # bandwidth to brentq's 1e-13
    assert near(sampled_frequency.m_peak(model), peak, 1e-9)
    assert near(sampled_frequency.bandwidth(model), bandwidth, 1e-9)


@pytest.mark.parametrize("case", sorted(CASES))
def test_ramp_error_is_python_controls_steady_state(case):
    """C_v = 1/e_ss after r(k) = kT: python-control's forced response of H to a ramp, read
    once the transient has decayed below 1e-15 (the loops' slowest pole |z| ≤ 0.99)."""
    model = model_of(case)
    _, closed = control_loops(case)
    radius = float(np.max(np.abs(control.poles(closed))))
    samples = math.ceil(math.log(1e-15) / math.log(radius)) + 10
    t = np.arange(samples) * PERIOD
    response = control.forced_response(closed, t, t)
    error = t[-1] - float(np.ravel(response.outputs)[-1])
    # e_ss ~ 1e-2 rad read from y ~ t ~ 1 rad: python-control's rounding of y is ~1e-15
    # rad, which is also all a type-2 loop's e_ss = 0 shows; 1e-12 rad is far below any
    # encoder's count (a 2^20 count per turn is 6e-6 rad)
    assert abs(model.ramp_following_error() - error) <= 1e-7 * abs(error) + 1e-12


def test_a_fractional_dead_time_is_the_drive_fed_the_delayed_held_commands():
    """θ = 2.3 T: between samples the model's position equals scipy's ODE solution
    (solve_ivp, DOP853) of the continuous drive fed u(k) from (k + 2.3)T on, interval by
    interval between the switches; the model's grid resolves the switch at 0.3 T."""
    options, tuned = {"velocity_controller": "pi", "dead_time": 2.3 * PERIOD}, CASES[
        "cascade-tustin"][1]
    model = SampledLinearModel(plant_of(options), {**tuned, "sampling_period": PERIOD})
    assert (model.whole, model.fraction) == (2, pytest.approx(0.3 * PERIOD, rel=1e-12))
    _, commands, _ = model.step_samples()
    t, e = model.step_error()
    keep = t <= 30 * PERIOD
    t, y = t[keep], 1.0 - e[keep]
    drive = drive_block(DRIVE)
    switches = np.concatenate([[0.0], np.arange(commands.size) * PERIOD + 2.3 * PERIOD])
    held = np.concatenate([[0.0], commands])  # nothing arrives before θ
    state, simulated = np.zeros(drive.order), np.empty_like(t)
    for k in range(np.searchsorted(switches, t[-1], side="right")):
        end = switches[k + 1] if k + 1 < switches.size else t[-1]
        inside = (t >= switches[k]) & (t < end) if k + 1 < switches.size else t >= switches[k]
        run = solve_ivp(lambda _, x, u=held[k]: drive.a @ x + drive.b[:, 0] * u,
                        (switches[k], max(end, switches[k])), state, method="DOP853",
                        t_eval=t[inside], rtol=1e-12, atol=1e-15, dense_output=True)
        simulated[inside] = drive.c[0] @ run.y if inside.any() else simulated[inside]
        state = run.sol(end) if end > switches[k] else state
    # the ODE solver's 1e-12 relative on a position of order 1 rad
    np.testing.assert_allclose(y, simulated, atol=1e-9)


def test_a_dead_time_just_short_of_a_whole_sample_is_that_sample():
    """θ → 3T from below: the fractional loop's poles approach those of θ = 3T
    continuously (the fraction is the hold split, not a different loop)."""
    tuned = {**CASES["p"][1], "sampling_period": PERIOD}
    whole = SampledLinearModel(plant_of({"dead_time": 3 * PERIOD}), tuned).poles()
    almost = SampledLinearModel(plant_of({"dead_time": 3 * PERIOD * (1 - 1e-7)}), tuned).poles()
    whole = np.sort_complex(whole[np.abs(whole) > 1e-3])
    almost = np.sort_complex(almost[np.abs(almost) > 1e-3])
    np.testing.assert_allclose(almost, whole, atol=1e-5)  # O(θ_f/T) = 1e-7·3, and √ of it
    # at a double pole


def test_the_bundled_sampled_example_is_covered_and_agrees():
    """The tuned result of examples/user-defined-sampled-drive.json (its `feedtune tune`
    output, stored): every reported metric has an entry, and every entry is within its
    tolerance; a metric moved by 1 % is caught."""
    result = json.loads((DATA / "user-defined-sampled-drive.result.json").read_text())
    block = validate_result(result)
    assert block["covered"] and block["ok"], block
    measured = {e["metric"] for e in block["entries"]}
    assert set(result["metrics"]) <= measured
    tampered = json.loads(json.dumps(result))
    tampered["metrics"]["phase_margin"]["value"] *= 1.01
    rows = {e["metric"]: e for e in validate_result(tampered)["entries"]}
    assert rows["phase_margin"]["ok"] is False


def test_the_model_is_registered_for_the_sampled_implementation():
    options, tuned = CASES["p"]
    model = model_for(plant_of(options), {**tuned, "sampling_period": PERIOD})
    assert isinstance(model, SampledLinearModel) and model.sampled
    with pytest.raises(NotCovered):  # a drive with direct feedthrough
        SampledLinearModel({**plant_of({}), "model": {"type": "state_space", "a": [[-1.0]],
                                                      "b": [[1.0]], "c": [[1.0]], "d": [[1.0]]}},
                           {**tuned, "sampling_period": PERIOD})


def test_a_step_response_beyond_the_point_budget_is_left_out(monkeypatch):
    """A loop that needs more dense points than MAX_POINTS (a slow loop at a short T) has
    no step integrals (NotCovered: its entries are left out), not an allocation of GBs."""
    import feedtune.validate.sampled_linear as sampled_linear

    model = model_of("p")
    samples = model.step_samples()[0].shape[0]
    monkeypatch.setattr(sampled_linear, "MAX_POINTS", samples * model._substeps() - 1)
    with pytest.raises(NotCovered, match="points"):
        model.error_integrals()
