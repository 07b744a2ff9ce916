"""Pulse-generator metrics against closed forms (feedtune.loops.pulse_train, Tian et al.)."""

from __future__ import annotations

import math

import pytest

from feedtune.objectives import METRICS
from feedtune.plants.pulse_generator import PulseGenerator, PulseGeneratorParams

DELTA = 1e-3  # m per pulse
F = 10e3  # Hz → v_max = 10 m/s


def loop(law=False, value=0.1, k=10.0, f=F, **params):
    p = PulseGeneratorParams(type="pulse_generator", pulse_equivalent=DELTA, position_unit="m",
                             acceleration_law=law, **params)
    return PulseGenerator(p).loop({"error_limit": value, "sampling_frequency": f,
                                   "acceleration_ratio": k})


def m(name, lp, **options):
    cls = METRICS[name]
    return cls().evaluate(lp, cls.Options(**options))


def test_ramp_below_the_max_rate_tracks_with_constant_lag():
    """In steady tracking the pulse rate v/δ equals f·e/value, so the lag is
    e = v·value/v_max = 2 · 0.1/10 = 20 mm; the counter and the rounded command add at
    most a pulse each side."""
    lp = loop(input="ramp", ramp_velocity=2.0, duration=0.2)
    assert m("pulse_final_error", lp) == pytest.approx(0.02, abs=2 * DELTA)
    assert lp.stability()["stable"]
    # v = δf·e/value: one pulse of e is 0.1 m/s
    assert m("pulse_max_velocity", lp) == pytest.approx(2.0, abs=0.11)


def test_ramp_above_the_max_rate_loses_track():
    lp = loop(input="ramp", ramp_velocity=20.0, duration=0.05)
    assert not lp.stability()["stable"]
    assert m("pulse_max_velocity", lp) == pytest.approx(10.0)


def test_saturated_step_rise_time_is_travel_at_v_max():
    """value = one pulse: every period sends a pulse, so 10 %→90 % of 1 m takes 800 pulses,
    800 periods = 80 ms exactly; no overshoot; at rest on target."""
    lp = loop(value=DELTA, amplitude=1.0)
    assert m("pulse_rise_time", lp) == pytest.approx(0.08, abs=1.5 / F)
    assert m("pulse_overshoot", lp) == 0.0
    assert m("pulse_settling_time", lp) == pytest.approx(0.1, abs=1.5 / F)
    assert m("pulse_final_error", lp) <= DELTA / 2


def test_settling_band_in_pulses():
    lp = loop(value=0.05, amplitude=0.5)
    tight, loose = m("pulse_settling_time", lp), m("pulse_settling_time", lp, band=10)
    assert 0 < loose < tight


def test_acceleration_law_bounds_commanded_acceleration_by_delta_f2_over_k():
    """Eq 2: |Δe| ≤ value/k per period ⇒ |a| ≤ δf²/k = 1e5/20 = 5 km/s², reached on the ramp."""
    lp = loop(law=True, k=20.0, amplitude=0.5)
    assert m("peak_commanded_acceleration", lp) == pytest.approx(DELTA * F**2 / 20, rel=1e-9)


def test_measured_acceleration_of_a_velocity_jump():
    """Without the law the pulse rate jumps to f: over a window of W periods the counter
    reads v_max after one window, so the measured acceleration is v_max/(W T) = 10/1e-3."""
    lp = loop(value=DELTA, amplitude=1.0)
    assert m("peak_measured_acceleration", lp, window=1e-3) == pytest.approx(1e4, rel=1e-9)
    assert m("peak_commanded_acceleration", lp) == pytest.approx(DELTA * F**2, rel=1e-9)


def test_sine_tracking_error_is_the_velocity_lag():
    """A slow sine (ω = 10 rad/s, A = 0.1 m, peak 1 m/s ≪ v_max) is tracked like a ramp of
    its local velocity: lag ≈ Aω·value/v_max = 0.1·10·0.1/10 = 10 mm (first order:
    A·ωτ with τ = value/v_max = 10 ms, ωτ = 0.1: |1 − 1/(1+jωτ)| A = 9.95 mm), to a pulse."""
    lp = loop(input="sine", amplitude=0.1, sine_frequency=10.0)
    tau = 0.1 / 10.0
    expected = 0.1 * 10 * tau / math.sqrt(1 + (10 * tau) ** 2)
    assert m("sine_tracking_error", lp) == pytest.approx(expected, abs=2 * DELTA)
    assert lp.stability()["stable"]


def test_motor_margin_zero_at_the_matching_k_and_negative_below():
    motor = [[0.0, 5e3], [F, 5e3]]
    k = DELTA * F**2 / 5e3  # = 20
    at = loop(law=True, k=k, amplitude=0.5, motor_characteristic=motor)
    below = loop(law=True, k=k / 2, amplitude=0.5, motor_characteristic=motor)
    assert m("motor_acceleration_margin", at) == pytest.approx(0.0, abs=1e-9)
    assert m("motor_acceleration_margin", below) == pytest.approx(-1.0, rel=1e-9)


def test_motor_margin_charges_rates_above_the_motor():
    motor = [[0.0, 1e9], [F / 2, 1e9]]  # the motor follows up to half the controller's rate
    lp = loop(value=DELTA, amplitude=0.5, motor_characteristic=motor)
    assert m("motor_acceleration_margin", lp) == pytest.approx(-1.0, rel=1e-9)


def test_units_follow_the_axis():
    assert METRICS["peak_commanded_acceleration"]().unit_of(None, "rad") == "rad/s²"
    assert METRICS["pulse_final_error"]().unit_of(None, "m") == "m"


def test_params_need_exactly_one_scale():
    with pytest.raises(ValueError):
        PulseGeneratorParams(type="pulse_generator")
    with pytest.raises(ValueError):
        PulseGeneratorParams(type="pulse_generator", pulse_equivalent=1e-3, max_velocity=1.0)
    p = PulseGeneratorParams(type="pulse_generator", max_velocity=430.0)
    lp = PulseGenerator(p).loop({"error_limit": 1.0, "sampling_frequency": 140e3,
                                 "acceleration_ratio": 430.0})
    assert lp.numbers["pulse_equivalent"] == pytest.approx(430.0 / 140e3)
