"""The validator's declared tables (feedtune.validate.measurements) and the measurements
added when the contract test (tests/contract/test_validator_contract.py) found metrics
reported unchecked: the radial error of every continuous loop, ζ and ω_n of a
second-order user-defined loop, and the pulse generator's sine tracking error.

Tolerances: closed forms of the same complex numbers agree to rounding (1e-12 relative);
the pulse generator runs the same integer arithmetic on both sides (1e-9 of a pulse δ,
as tolerances.RULES judges it).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import casadi as ca
import pytest

from feedtune.objectives import METRICS
from feedtune.plants import PLANTS
from feedtune.validate import sampled_frequency, validate_result
from feedtune.validate.block import is_measured
from feedtune.validate.linear import LinearModel
from feedtune.validate.pulse_generator import PulseModel
from feedtune.validate.software_servo import ServoModel

TAU = 0.01  # [s] the drive 1/(s(τs + 1)) [rad/V]
PLANT = {"type": "linear", "output_unit": "rad",
         "model": {"type": "transfer_function", "numerator": [1.0], "denominator": [TAU, 1.0, 0.0]}}


def _closed(gain: float, omega: float) -> complex:
    """H(jω) = K/(τ(jω)² + jω + K) of the P-controlled drive."""
    s = 1j * omega
    return gain / (TAU * s * s + s + gain)


@pytest.mark.parametrize("gain, radius, feed", [(20.0, 0.01, 0.02), (50.0, 0.05, 0.5),
                                                (80.0, 0.002, 0.001)])
def test_linear_radial_error_is_the_closed_form(gain, radius, feed):
    """r·| |H(jω)| − 1 |, ω = feed/r (Koren eq 37 in exact form)."""
    model = LinearModel(PLANT, {"position_controller.kp": gain})
    table = {k: v for phase in model.measurement_tables() for k, v in phase.table.items()}
    got = table["radial_error"].measure(model, {"radius": radius, "feed": feed}, None, {})
    exact = radius * abs(abs(_closed(gain, feed / radius)) - 1.0)
    assert got == pytest.approx(exact, rel=1e-9, abs=1e-12 * radius)


@pytest.mark.parametrize("gain", [5.0, 25.0, 100.0])
def test_linear_second_order_pair_is_the_closed_form(gain):
    """K/(s(τs + 1)) closes to ω_n = √(K/τ), ζ = 1/(2√(Kτ)) (Koren eqs 9–10)."""
    result = _result(gain)
    entries = {e["metric"]: e for e in validate_result(result)["entries"]}
    wn = math.sqrt(gain / TAU)
    assert entries["natural_frequency"]["validated"] == pytest.approx(wn, rel=1e-12)
    assert entries["damping_ratio"]["validated"] == pytest.approx(1 / (2 * math.sqrt(gain * TAU)),
                                                                  rel=1e-12)


def _result(gain: float, radial_error: float | None = None) -> dict:
    """A result of the linear plant reporting the pair and a radial error at their true
    values (or ``radial_error`` [m])."""
    wn, zeta = math.sqrt(gain / TAU), 1 / (2 * math.sqrt(gain * TAU))
    radius, feed = 0.01, 0.02
    true_radial = radius * abs(abs(_closed(gain, feed / radius)) - 1.0)
    metrics = {
        "natural_frequency": {"metric": "natural_frequency", "value": wn, "unit": "rad/s",
                              "options": {}},
        "damping_ratio": {"metric": "damping_ratio", "value": zeta, "unit": "1", "options": {}},
        "radial_error": {"metric": "radial_error", "unit": "m",
                         "value": true_radial if radial_error is None else radial_error,
                         "options": {"radius": radius, "feed": feed}},
    }
    return {"spec": {"plant": PLANT},
            "tuned": {"position_controller.kp": {"value": gain, "unit": "V/rad"}},
            "metrics": metrics, "stability": {}}


def test_block_checks_and_flags_the_radial_error_of_a_linear_loop():
    """The entry exists and agrees; moved by 1 µm (1000 × its scale 1e-9·r) it fails."""
    good = {e["metric"]: e for e in validate_result(_result(30.0))["entries"]}
    assert good["radial_error"]["ok"] is True
    wrong = validate_result(_result(30.0, radial_error=good["radial_error"]["validated"] + 1e-6))
    entry = next(e for e in wrong["entries"] if e["metric"] == "radial_error")
    assert entry["ok"] is False and wrong["ok"] is False


def test_sine_tracking_error_is_the_tuners():
    """Tian §4, Fig 5: the tuner's pulse simulation and the validator's period-by-period
    run give the same largest error over the last sine period."""
    cls = PLANTS["pulse_generator"]
    plant = cls(cls.Params(type="pulse_generator", pulse_equivalent=1e-3, amplitude=0.5,
                           input="sine", sine_frequency=10.0))
    tunables = plant.tunables()
    point = {n: math.sqrt(t.min * t.max) for n, t in tunables.items()}
    loop = plant.loop(point, {n: (t.min, t.max) for n, t in tunables.items()})
    tuner = float(METRICS["sine_tracking_error"]().evaluate(loop, None))
    model = PulseModel(plant.params.model_dump(mode="json"), point, loop.response.horizon)
    assert is_measured(model, "sine_tracking_error", {})
    assert tuner > 10 * 1e-3  # a real tracking error, many pulses: the check can fail
    assert model.metric("sine_tracking_error", {}) == pytest.approx(tuner, abs=1e-9 * 1e-3)


def test_is_measured_reads_the_table(monkeypatch):
    """The contract test asks :func:`is_measured`; it answers from the declared tables."""
    model = ServoModel(20.0, 0.02, 0.01, 1)
    assert is_measured(model, "sensitivity_peak", {})
    continuous = ServoModel(20.0, 0.02)  # its own, closed-form table of frequency metrics
    assert is_measured(continuous, "sensitivity_peak", {})
    assert not is_measured(continuous, "overshoot", {})  # a sampled loop's table only
    assert not is_measured(model, "settling_time", {"input": "ramp", "band": 0.02})
    monkeypatch.delitem(sampled_frequency.MEASUREMENTS, "sensitivity_peak")
    assert not is_measured(model, "sensitivity_peak", {})


@pytest.mark.parametrize("stored", ["ward-leonard-feed-drive", "bhatia-1971-hydraulic"])
def test_cascade_radial_error_agrees_with_the_tuner(stored):
    """Bhatia's cascades at their stored tuned values: the tuner's radial error (from its
    error response S) and the validator's (from its own state-space |H|) agree within the
    entry's tolerance; they differed by ≤ 1.3e-13 relative when measured (2026-11-25)."""
    data = json.loads((Path(__file__).parents[1] / "data" / f"{stored}.result.json").read_text())
    plant_spec = data["spec"]["plant"]
    cls = PLANTS[plant_spec["type"]]
    plant = cls(cls.Params(**plant_spec))
    tuned = {name: t["value"] for name, t in data["tuned"].items()}
    box = {name: (t["min"], t["max"]) for name, t in data["tuned"].items()}
    metric = METRICS["radial_error"]
    options = metric.Options(radius=0.01, feed=0.05)
    value = metric().evaluate(plant.loop(tuned, box), options)  # a Magnitude: |expr|
    reported = abs(float(ca.evalf(ca.MX(value.expr))))
    result = {**data, "metrics": {"radial_error": {
        "metric": "radial_error", "value": reported, "unit": "m",
        "options": options.model_dump(mode="json")}}}
    (entry,) = [e for e in validate_result(result)["entries"] if e["metric"] == "radial_error"]
    assert reported > 0 and entry["ok"] is True
    assert entry["gap"] <= 1e-9 * reported  # far inside the tolerance: both exact
