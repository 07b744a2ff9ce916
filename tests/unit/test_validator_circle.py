"""The validator's time-domain circle test and ramp response, against closed forms, and the
circle metrics of a tuned Sato example against the tuner's closed-form periodic steady
state (feedtune/objectives/contour/circle_test.py: a different method for the same quantity).

Tolerances: the continuous loop follows r·e^{jωt} through the exact exponential of the
augmented system (rounding only, 1e-12 of r); sampled loops at the samples likewise.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from feedtune.validate import validate_result
from feedtune.validate.software_servo import SUBSTEPS, ServoModel

TAU = 0.02


@pytest.mark.parametrize("gain", [10.0, 25.0, 60.0])
def test_continuous_circle_is_r_times_the_closed_loop_gain(gain):
    """Koren eq 28: the reference-pulse loop's steady circle has radius r|H(jω)| at every
    angle, H = K/(τ(jω)² + jω + K)."""
    radius, feed = 0.008, 0.04
    omega = feed / radius
    h = abs(gain / (TAU * (1j * omega) ** 2 + 1j * omega + gain))
    trace = ServoModel(gain, TAU).circle_test(radius, feed)
    assert np.max(np.abs(trace.deviation - radius * (h - 1))) < 1e-12 * radius
    assert np.ptp(np.unwrap(trace.angle)) == pytest.approx(2 * math.pi, rel=1e-3)


@pytest.mark.parametrize("gain, tau, period, delay", [(18.0, TAU, 0.015625, 0),
                                                      (40.0, None, 0.002, 1),
                                                      (30.0, TAU, 0.01, 1)])
def test_sampled_ramp_error_settles_on_one_over_the_velocity_constant(gain, tau, period, delay):
    """A type-1 loop follows a unit ramp with the error 1/C_v at the samples, C_v = K
    (Koren eq 5; the ramp reference read at the samples)."""
    model = ServoModel(gain, tau, period, delay)
    ramp = model.responses()["ramp"]
    at_samples = ramp.error[::SUBSTEPS]
    assert at_samples[-1] == pytest.approx(1 / gain, rel=1e-9)
    assert ramp.time[-1] > 10 * period


def test_continuous_ramp_error_settles_on_one_over_k():
    """K/(s(1+sτ)) under r = t: e(∞) = 1/K (Koren eq 5); the trapezoid's O(h²) is ~1e-6."""
    ramp = ServoModel(25.0, TAU).responses()["ramp"]
    assert ramp.error[-1] == pytest.approx(1 / 25.0, rel=1e-5)


def test_sato_circle_metrics_agree_with_the_tuner():
    """sato-finish (exact sampled loop, q = 5, delay 1) tuned in-process: the time
    simulation re-measures the mean deviation, circularity and roughness within tolerance,
    and the deviation is the polygon's: every point inside the circle (mean −1e-5 m)."""
    from feedtune.problem import tune
    from feedtune.schema.spec import parse_spec

    spec = parse_spec((Path(__file__).resolve().parents[2] / "examples" /
                       "sato-finish.json").read_bytes())
    result = tune(spec).model_dump(mode="json")
    block = validate_result(result)
    rows = {e["metric"]: e for e in block["entries"]}
    for name in ("circle_mean_deviation", "circularity", "circle_roughness"):
        assert rows[name]["ok"], rows[name]
    assert block["ok"] is True
    tuned = {k: v["value"] for k, v in result["tuned"].items()}
    model = ServoModel.from_result(result["spec"]["plant"], tuned)
    assert model.reference_interval == pytest.approx(tuned["reference_interval"])
    assert np.max(model.circle_test(0.05, 0.05).deviation) < 0


@pytest.mark.parametrize("gain, period", [(18.0, None), (18.0, 0.015625), (25.0, 0.002)])
def test_min_radius_is_the_largest_root_of_the_blu_criterion(gain, period):
    """Koren eqs 30–32: at r_min the radial error at V_m is BLU/2; above it, less."""
    blu, v = 1e-5, 0.04
    model = ServoModel(gain, TAU, period, blu=blu, max_velocity=v)
    r = model.min_radius()
    assert model.radial_error(r, v) == pytest.approx(blu / 2, rel=1e-9)
    assert all(model.radial_error(r * f, v) < blu / 2 for f in (1.01, 2.0, 10.0, 100.0))


@pytest.mark.parametrize("name, decrease", [("sato-table2-a", 297.22e-6), ("sato-table2-b", 83.24e-6)])
def test_pade_model_results_validate_on_the_pade_loop(name, decrease):
    """Sato's Padé model (eq 5, no τ): the closed loop K(2/L − s)/(s² + (2/L − K)s + 2K/L),
    so ω_n = √(2K/L), ζ = (2/L − K)/(2ω_n); eq 7 gives Table 2's Δr (297 and 83 µm; 297.22
    and 83.24 µm unrounded, docs/sato.md). Every metric the tuner reports on this model is
    re-measured within tolerance."""
    from feedtune.problem import tune
    from feedtune.schema.spec import parse_spec

    spec = parse_spec((Path(__file__).resolve().parents[2] / "examples" / f"{name}.json").read_bytes())
    result = tune(spec).model_dump(mode="json")
    block = validate_result(result)
    assert block["covered"] and block["ok"] is True, block
    rows = {e["metric"]: e for e in block["entries"]}
    k = result["tuned"]["position_gain"]["value"]
    dead = (result["spec"]["plant"]["computation_delay"] + 0.5) * result["tuned"]["sampling_period"]["value"]
    wn = math.sqrt(2 * k / dead)
    assert rows["natural_frequency"]["validated"] == pytest.approx(wn, rel=1e-12)
    assert rows["damping_ratio"]["validated"] == pytest.approx((2 / dead - k) / (2 * wn), rel=1e-12)
    assert rows["radius_decrease"]["validated"] == pytest.approx(decrease, abs=0.01e-6)
    assert rows["m_peak"]["validated"] == 1.0  # |H| ≤ |H(0)|: the supremum is the DC limit
    assert {"bandwidth", "phase_margin", "iae", "settling_time", "poles"} <= set(rows)
