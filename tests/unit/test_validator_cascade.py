"""The validator's cascade models (Bhatia's hydraulic and Ward-Leonard drives) against
closed forms before they judge results:

* a first-order drive g/(τs + 1) under the two loops, no compensators, is Koren's
  K/(s(1 + sτ')) with K = K'_pK'_v g/(1 + K'_v g), τ' = τ/(1 + K'_v g): M_peak, bandwidth,
  crossover, phase margin, overshoot, ISE, C_v of the second-order loop;
* the static load errors of both drives (App. A2, App. B) and Bhatia's sensitivity;
* L and H of the example drives against python-control's interconnection of the same
  transfer functions (an independent implementation of the block algebra);
* the stored example results validate with every gap inside its tolerance.

Tolerances: frequency metrics and extremes are refined by Brent to 1e-12 or better, so
1e-9 relative; integrals are trapezoids on a grid of ≤ 0.01/|p| steps: ~1e-5 relative.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import control
import numpy as np
import pytest

from test_ward_leonard import compensator as control_compensator

from feedtune.validate import validate_result
from feedtune.validate.cascade import Block, CascadeModel, compensator, siso
from feedtune.validate.hydraulic_rotary import HydraulicRotaryModel
from feedtune.validate.ward_leonard import WardLeonardModel

DATA = Path(__file__).resolve().parents[1] / "data"


def first_order(gain: float, tau: float, kp: float, kv: float) -> CascadeModel:
    drive = Block(np.array([[-1 / tau]]), np.array([[gain / tau, -1 / tau]]), np.array([[1.0]]),
                  np.zeros((1, 2)))
    return CascadeModel(drive, kp, kv, siso([1.0], [1.0]), siso([1.0], [1.0]), True)


@pytest.mark.parametrize("kp, kv", [(20.0, 2.0), (50.0, 1.0), (8.0, 4.0)])
def test_first_order_cascade_is_the_second_order_loop(kp, kv):
    g, tau = 3.0, 0.05
    k = kp * kv * g / (1 + kv * g)
    tau_eq = tau / (1 + kv * g)
    wn, zeta = math.sqrt(k / tau_eq), 1 / (2 * math.sqrt(k * tau_eq))
    model = first_order(g, tau, kp, kv)
    assert model.velocity_constant() == pytest.approx(k, rel=1e-12)
    assert model.bandwidth() == pytest.approx(
        wn * math.sqrt(1 - 2 * zeta**2 + math.sqrt(2 - 4 * zeta**2 + 4 * zeta**4)), rel=1e-9)
    wc = wn * math.sqrt(math.sqrt(1 + 4 * zeta**4) - 2 * zeta**2)
    assert model.crossover() == pytest.approx(wc, rel=1e-9)
    assert model.phase_margin() == pytest.approx(math.degrees(math.atan(2 * zeta * wn / wc)),
                                                 rel=1e-9)
    if zeta < math.sqrt(0.5):
        assert model.m_peak() == pytest.approx(1 / (2 * zeta * math.sqrt(1 - zeta**2)), rel=1e-9)
    assert model.gain_margin() == math.inf  # a second-order loop's phase never reaches −180°
    rows = {(r["metric"], r["options"].get("input")): r for r in model.measure({"metrics": {
        "o": {"metric": "overshoot", "value": 1.0},
        "i": {"metric": "ise", "value": 1.0, "options": {"input": "step"}}}})}
    overshoot = math.exp(-zeta * math.pi / math.sqrt(1 - zeta**2)) if zeta < 1 else 0.0
    assert rows[("overshoot", None)]["validated"] == pytest.approx(overshoot, rel=1e-9, abs=1e-12)
    assert rows[("ise", "step")]["validated"] == pytest.approx(
        (1 + 4 * zeta**2) / (4 * zeta * wn), rel=1e-5)


def test_first_order_static_load_error():
    """θ̇ = (g u − T_L)/(τs + 1): at rest g·K'_v·K'_p·e = T_L, e = 1/(g K'_v K'_p) per N·m."""
    model = first_order(3.0, 0.05, 20.0, 2.0)
    steady = model._error("load")[3]
    assert steady == pytest.approx(1 / (3.0 * 2.0 * 20.0), rel=1e-12)


def _tuned(path: Path) -> tuple[dict, dict]:
    result = json.loads(path.read_text())
    return result["spec"]["plant"], {k: v["value"] for k, v in result["tuned"].items()}


def test_ward_leonard_static_load_error_and_sensitivity():
    """App. B: e_ss = R_a T_L/(K'_p K'_v k_t K'_c/R_fg); G(0) = k_t K'_c/(R_fg(R_a B_m + k_t k_b))."""
    plant, tuned = _tuned(DATA / "ward-leonard-feed-drive.result.json")
    model = WardLeonardModel.from_result(plant, tuned)
    kp, kv = tuned["position_gain"], tuned["velocity_gain"]
    field = plant["generator_gain"] / plant["generator_field_resistance"]
    steady = model._error("load")[3]
    assert steady == pytest.approx(plant["armature_resistance"]
                                   / (kp * kv * plant["torque_constant"] * field), rel=1e-9)
    g0 = plant["torque_constant"] * field / (plant["armature_resistance"] * plant["viscous_damping"]
                                              + plant["torque_constant"] * plant["back_emf_constant"])
    assert model.sensitivity() == pytest.approx(g0 * kv * kp, rel=1e-12)


def test_hydraulic_static_load_error():
    """App. A2 at rest: (K_q/D_m)·K_s·K'_v·K'_p·e = (K_ce/D_m²)·T_L."""
    plant, tuned = _tuned(DATA / "bhatia-1971-hydraulic.result.json")
    model = HydraulicRotaryModel.from_result(plant, tuned)
    dm = plant["displacement"]
    expected = (plant["leakage_coefficient"] / dm**2) / (
        plant["flow_gain"] / dm * plant["torque_motor_gain"] * tuned["velocity_gain"]
        * tuned["position_gain"])
    assert model._error("load")[3] == pytest.approx(expected, rel=1e-9)


def _control_loops(plant: dict, tuned: dict, velocity_per_volt) -> tuple:
    """L and H by python-control's own block algebra (series, feedback) of the same blocks."""
    def comp(prefix):
        name = f"{prefix}_compensator"
        return control_compensator(plant[name], name, tuned)

    inner = control.feedback(tuned["velocity_gain"] * comp("velocity") * velocity_per_volt)
    open_loop = tuned["position_gain"] * comp("position") * inner * control.tf([1], [1, 0])
    return open_loop, control.feedback(open_loop)


@pytest.mark.parametrize("name", ["bhatia-1971-hydraulic", "ward-leonard-feed-drive"])
def test_loops_match_python_control(name):
    plant, tuned = _tuned(DATA / f"{name}.result.json")
    if plant["type"] == "hydraulic_rotary":
        model = HydraulicRotaryModel.from_result(plant, tuned)
        wn, z = plant["hydraulic_natural_frequency"], plant["hydraulic_damping"]
        g = control.tf([plant["torque_motor_gain"] * plant["flow_gain"] / plant["displacement"]],
                       np.polymul([plant["torque_motor_time_constant"], 1],
                                  [1 / wn**2, 2 * z / wn, 1]))
    else:
        model = WardLeonardModel.from_result(plant, tuned)
        p = plant
        d = np.polyadd(np.polymul([p["armature_inductance"], p["armature_resistance"]],
                                  [p["inertia"], p["viscous_damping"]]),
                       [p["torque_constant"] * p["back_emf_constant"]])
        g = control.tf([p["torque_constant"] * p["generator_gain"] / p["generator_field_resistance"]],
                       np.polymul([p["generator_field_inductance"] / p["generator_field_resistance"], 1], d))
    open_loop, closed = _control_loops(plant, tuned, g)
    omega = np.logspace(-1, 4, 60)
    lo, h = model.frequency_response(omega)
    assert np.max(np.abs(lo / open_loop(1j * omega) - 1)) < 1e-9
    assert np.max(np.abs(h / closed(1j * omega) - 1)) < 1e-9
    gm, pm, _, _ = control.margin(open_loop)
    assert model.phase_margin() == pytest.approx(pm, rel=1e-6)
    assert model.gain_margin() == pytest.approx(gm, rel=1e-6)


def test_lag_lead_compensator_block():
    tuned = {"c.tau1": 0.1, "c.tau2": 0.02, "c.tau12": 0.5}
    block = compensator("lag_lead", "c", tuned)
    s = 1j * np.logspace(-2, 3, 30)
    exact = (1 + 0.1 * s) * (1 + 0.02 * s) / (0.002 * s**2 + 0.62 * s + 1)
    got = np.array([(block.c @ np.linalg.solve(si * np.eye(2) - block.a, block.b))[0, 0]
                    + block.d[0, 0] for si in s])
    assert np.max(np.abs(got / exact - 1)) < 1e-12


@pytest.mark.parametrize("name", ["bhatia-1971-hydraulic", "ward-leonard-feed-drive"])
def test_example_results_validate(name):
    block = validate_result(json.loads((DATA / f"{name}.result.json").read_text()))
    assert block["covered"] and block["ok"] is True, block
    measured = {e["metric"] for e in block["entries"]}
    assert {"m_peak", "bandwidth", "gain_margin", "phase_margin", "crossover_frequency",
            "velocity_constant", "sensitivity", "iae", "ise", "itae", "settling_time",
            "overshoot", "load_rejection", "poles", "velocity_loop_poles", "stable"} <= measured
    # none of these values is near zero: relative to the value, the gaps are below 1e-5
    assert max(e["gap"] / abs(e["validated"]) for e in block["entries"]
               if e["gap"] is not None and e["metric"] not in ("poles", "velocity_loop_poles")) < 1e-5
