"""The independent validator of data-driven results (feedtune/validate/frequency_data.py):
it re-evaluates the tuned controller on every measured frequency of every set with its own
arithmetic, counts the Nyquist turn again, and says which bounds hold; a result whose gains,
metrics or stability were altered after the design fails it."""

from __future__ import annotations

import copy
import json
import math
from pathlib import Path

import numpy as np
import pytest

import feedtune
from feedtune.validate import validate_result
from feedtune.validate.frequency_data import (MeasuredLoop, controller_response, nyquist_count,
                                              spline_peak)

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "examples" / "datadriven" / "hydraulic-three-loads.json"

#: Bhatia's rotary hydraulic drive [rad/V] (tests/unit/test_datadriven.py)
GAIN, TAU, OMEGA_N, XI = 0.254 * 5.44225e-06 / 1.38233e-07, 0.01, 75.0, 0.5
OMEGA = np.logspace(-1, 4, 500)


@pytest.fixture(scope="module")
def result() -> dict:
    tuned = feedtune.tune(json.loads(EXAMPLE.read_text()))
    assert tuned.success, tuned.message
    return json.loads(tuned.to_json())


def failing(block: dict) -> set[tuple]:
    return {(e["metric"], tuple(sorted(e["options"].items())))
            for e in block["entries"] if not e["ok"]}


def test_the_example_is_covered_and_agrees(result):
    """Every reported metric of every set and the worst over the sets re-measured, every
    bound held on every set with its measured worst value, every set stable by a count of
    its own; nothing outside its tolerance."""
    block = result["validation"]
    assert block["covered"] is True and block["ok"] is True, failing(block)
    sets = [s["name"] for s in result["spec"]["plant"]["sets"]]
    rows = {(e["metric"], e["options"].get("set"), "bound" in e["options"]): e
            for e in block["entries"]}
    for name in sets:
        for metric in ("m_peak", "sensitivity_peak", "bandwidth", "crossover_frequency",
                       "phase_margin"):
            assert (metric, name, False) in rows
        for metric, bound in (("m_peak", 1.3), ("sensitivity_peak", 2.0)):
            row = rows[(metric, name, True)]
            assert row["held"] is True and row["bound"] == bound
            assert row["measured_worst"] <= row["worst"] <= bound * (1 + 1e-6)
            assert OMEGA[0] <= row["measured_at"] <= OMEGA[-1]
        stable = rows[("stable", name, False)]
        assert stable["validated"] is True and stable["rhp_poles"] == 0
        # n = 2: (2 + 0)·π/2, up to the plant's phase offset from −90° at the lowest point
        # (0.1 rad/s: ω(τ + 2ξ/ω_n) ≈ 2e-3 rad, and the 1 % noise, 1e-2 rad)
        assert stable["turn_rad"] == pytest.approx(math.pi, abs=2e-2)
    # the worst over the sets is the result's headline value
    assert rows[("bandwidth", None, False)]["reported"] == result["metrics"]["bandwidth"]["value"]


def test_altered_gains_fail_validation(result):
    """k_p raised 30 % after the design: the reported peaks and crossings no longer match
    the loop the gains make (gaps far above the data's interpolation corrections)."""
    tampered = copy.deepcopy(result)
    tampered["tuned"]["controller.kp"]["value"] *= 1.3
    block = validate_result(tampered)
    assert block["covered"] is True and block["ok"] is False
    failed = failing(block)
    assert ("bandwidth", ()) in failed and ("crossover_frequency", ()) in failed


def test_a_violated_bound_is_reported_with_its_worst_value(result):
    """k_d halved: the double load's |T| peak exceeds 1.3, which the result still claims
    to hold; the bound's row says violated, with the measured worst value above the bound."""
    tampered = copy.deepcopy(result)
    tampered["tuned"]["controller.kd"]["value"] *= 0.5
    block = validate_result(tampered)
    bound = [e for e in block["entries"] if e["metric"] == "m_peak"
             and e["options"].get("bound") and e["options"]["set"] == "double-load"]
    assert len(bound) == 1 and bound[0]["held"] is False and bound[0]["ok"] is False
    assert bound[0]["measured_worst"] > 1.3 and bound[0]["claimed"] is True
    assert bound[0]["reported"] == 1.3 and bound[0]["validated"] >= bound[0]["measured_worst"]
    assert block["ok"] is False


def test_altered_metrics_or_stability_fail_validation(result):
    """A reported M_peak lowered by 1e-3 (above the double load's interpolation correction,
    5e-4) and a set's stability flipped: exactly those entries fail."""
    tampered = copy.deepcopy(result)
    tampered["metrics"]["m_peak(set=double-load)"]["value"] -= 1e-3
    tampered["stability"]["sets"][0]["stable"] = False
    block = validate_result(tampered)
    assert failing(block) == {("m_peak", (("set", "double-load"),)),
                              ("stable", (("set", "half-load"),))}


def hydraulic(omega):
    s = 1j * np.asarray(omega)
    return GAIN / (s * (TAU * s + 1) * (s**2 / OMEGA_N**2 + 2 * XI * s / OMEGA_N + 1))


SWEEP = [("p", {"controller.kp": g}) for g in (0.3, 1.0, 3.0, 6.0, 9.0, 12.0, 30.0)] + [
    ("pi", {"controller.kp": 2.0, "controller.ki": 1.0}),
    ("pi", {"controller.kp": 2.0, "controller.ki": 60.0}),
    ("pi", {"controller.kp": 8.0, "controller.ki": 2.0}),
    ("pid", {"controller.kp": 2.0, "controller.ki": 20.0, "controller.kd": 0.07}),
    ("pid", {"controller.kp": 10.0, "controller.ki": 5.0, "controller.kd": 0.2}),
    ("pid", {"controller.kp": 1.0, "controller.ki": 200.0, "controller.kd": 0.01})]


def closed_loop_roots(law: str, gains: dict) -> np.ndarray:
    """numpy's roots of den_G·den_K + GAIN·num_K."""
    s_den = np.polymul(np.polymul([TAU, 1], [1 / OMEGA_N**2, 2 * XI / OMEGA_N, 1]), [1, 0])
    kp, ki, kd = (gains.get(f"controller.{k}", 0.0) for k in ("kp", "ki", "kd"))
    num, den = np.array([kp]), np.array([1.0])
    if "d" in law:
        num, den = np.polyadd(np.polymul([kp], [0.002, 1]), [kd, 0]), np.array([0.002, 1])
    if "i" in law:
        num, den = np.polyadd(np.polymul(num, [1, 0]), np.polymul([ki], den)), np.polymul(den, [1, 0])
    return np.roots(np.polyadd(np.polymul(s_den, den), GAIN * num))


def test_the_sweep_holds_stable_and_unstable_loops():
    """The next test cannot pass by always counting one thing."""
    counts = {int(np.sum(closed_loop_roots(law, gains).real > 0)) for law, gains in SWEEP}
    assert 0 in counts and max(counts) >= 2


@pytest.mark.parametrize("law, gains", SWEEP)
def test_the_count_agrees_with_the_closed_loop_roots(law, gains):
    """The validator's own Nyquist count against numpy's roots of the characteristic
    polynomial den_G·den_K + GAIN·num_K (a count: exact)."""
    plant = {"controller": law, "filter_time_constant": 0.002 if "d" in law else None}
    loop = MeasuredLoop("set", OMEGA, hydraulic(OMEGA),
                        controller_response(plant, gains, OMEGA), None)
    count = nyquist_count(loop, 1, 1 if "i" in law else 0, 0, plant, gains)
    roots = closed_loop_roots(law, gains)
    if count["rhp_poles"] is None:
        # no count only where 1 + L passes 0 between two measured points: a closed-loop
        # pole within 0.05 of the jω axis in damping (3°), as the design's certificate
        assert "not resolved" in count["reason"]
        assert np.min(np.abs(roots.real) / np.abs(roots)) < 0.05
        return
    assert count["rhp_poles"] == int(np.sum(roots.real > 0)), count["reason"]


def test_spline_peak_refines_a_peak_between_points():
    """A resonance |1/(1 − (ω/ω_r)² + 2jζω/ω_r)| with its peak between points of a 100-a-
    decade grid: the spline's peak is nearer the true one than the measured maximum."""
    w = np.logspace(0, 2, 201)
    zeta, wr = 0.1, 10.37
    value = np.abs(1 / (1 - (w / wr) ** 2 + 2j * zeta * w / wr))
    true = 1 / (2 * zeta * math.sqrt(1 - zeta**2))
    peak, at = spline_peak(w, value)
    assert abs(peak - true) < abs(value.max() - true) / 10
    assert at == pytest.approx(wr * math.sqrt(1 - 2 * zeta**2), rel=1e-3)
