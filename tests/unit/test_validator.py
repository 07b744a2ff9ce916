"""feedtune.validate, the numpy/scipy re-simulation, proved against closed forms before it is
trusted to judge a result: first- and second-order step responses, Koren eq 16 (sampled
step response) and eq 19 (damping), C_v = K (eq 5), the poles of the delayed loop, and the
two-axis circle test in time against the frequency response.

Tolerances: the state at every grid point comes from expm and is exact to rounding
(1e-12 on O(1) signals); the step integrals are a trapezoid on ≥ 256 sub-steps per
block, exact for linear pieces (the ideal drive) and off by ~(h·ω)²/12 otherwise, hence
1e-6 relative there (the estimate is 1e-8 for the loops below).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from feedtune.batch.reports import failure, row_ok
from feedtune.plants.software_servo import koren_step_response
from feedtune.validate import validate_result, warning_lines
from feedtune.validate.software_servo import CIRCLE_SUBSTEPS, ServoModel

TAU = 0.02


# -- second order, continuous (Koren eqs 3–10) ---------------------------------------------

@pytest.mark.parametrize("gain", [5.0, 12.5, 25.0, 100.0])
def test_reference_pulse_step_is_the_second_order_closed_form(gain):
    """K/(s(1+sτ)) closes to ω_n = √(K/τ), ζ = 1/(2√(Kτ)) (Koren eqs 9–10); the error is
    e^{−ζω_n t}(cos ω_d t + ζ/√(1−ζ²) sin ω_d t) (underdamped) or its limits."""
    model = ServoModel(gain, TAU)
    zeta, wn = model.equivalent_pair()
    assert wn == pytest.approx(math.sqrt(gain / TAU), rel=1e-12)
    assert zeta == pytest.approx(1 / (2 * math.sqrt(gain * TAU)), rel=1e-12)
    t, e, _ = model.step_error()
    if zeta < 1:
        wd = wn * math.sqrt(1 - zeta**2)
        exact = np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta / math.sqrt(1 - zeta**2) * np.sin(wd * t))
    elif zeta == 1:
        exact = (1 + wn * t) * np.exp(-wn * t)
    else:
        s1, s2 = np.roots([1, 2 * zeta * wn, wn**2])
        exact = (s1 * np.exp(s2 * t) - s2 * np.exp(s1 * t)) / (s1 - s2)
    assert np.max(np.abs(e - exact)) < 1e-12


def test_critically_damped_integrals_are_exact():
    """Kτ = 1/4: e = (1 + x)e^{−x}, x = ω_n t, so IAE = 2/ω_n, ISE = 5/(4ω_n), ITAE = 3/ω_n²."""
    model = ServoModel(1 / (4 * TAU), TAU)
    wn = 1 / (2 * TAU)
    got = model.error_integrals()
    assert got["iae"] == pytest.approx(2 / wn, rel=1e-6)
    assert got["ise"] == pytest.approx(1.25 / wn, rel=1e-6)
    assert got["itae"] == pytest.approx(3 / wn**2, rel=1e-6)


def test_underdamped_ise_is_the_closed_form():
    """ISE of ë + 2ζω_n ė + ω_n² e = 0, e(0) = 1, ė(0) = 0: (1 + 4ζ²)/(4ζω_n)."""
    model = ServoModel(50.0, TAU)
    zeta, wn = model.equivalent_pair()
    assert model.error_integrals()["ise"] == pytest.approx((1 + 4 * zeta**2) / (4 * zeta * wn),
                                                           rel=1e-6)


# -- first order, sampled ideal drive (Sato Fig 1 without delay) -----------------------------

@pytest.mark.parametrize("gain, period", [(20.0, 0.01), (50.0, 0.002), (80.0, 0.01)])
def test_sampled_ideal_drive_is_first_order(gain, period):
    """x(n+1) = x(n) + KT(1 − x(n)): e(n) = aⁿ, a = 1 − KT, linear between samples, so
    IAE = T(1 + a)/(2(1 − a)) and ISE = T(1 + a + a²)/(3(1 − a²)) for 0 < a < 1 (exact:
    the trapezoid is exact on linear pieces)."""
    model = ServoModel(gain, None, period)
    a = 1 - gain * period
    t, e, dt = model.step_error(substeps=4)
    samples = e[::4]
    assert np.max(np.abs(samples - a ** np.arange(len(samples)))) < 1e-12
    got = model.error_integrals()
    assert got["iae"] == pytest.approx(period * (1 + a) / (2 * (1 - a)), rel=1e-9)
    assert got["ise"] == pytest.approx(period * (1 + a + a * a) / (3 * (1 - a * a)), rel=1e-9)
    # the continuous first-order limit, T → 0: IAE → 1/K (here (2 − KT)/(2K), KT ≤ 0.008)
    assert ServoModel(gain, None, 1e-4).error_integrals()["iae"] == pytest.approx(
        1 / gain, rel=gain * 1e-4)


# -- Koren eq 16 and 19, sampled with a time constant -----------------------------------------

@pytest.mark.parametrize("gain, period", [(18.0, 0.015625), (30.0, 0.01), (10.0, 0.03)])
def test_sampled_step_is_koren_eq_16(gain, period):
    """W(n)/V = 1 − e^{−nαT}(cos nωT + M sin nωT) at the samples; ζ is eq 19."""
    model = ServoModel(gain, TAU, period)
    t, e, _ = model.step_error(substeps=8)
    position = 1 - e[::8]
    koren, _, _, _, zeta = koren_step_response(gain, period, TAU, len(position))
    assert np.max(np.abs(position - koren)) < 1e-12
    assert model.equivalent_pair()[0] == pytest.approx(zeta, rel=1e-10)


def test_intersample_error_is_the_drive_between_samples():
    """Inside a sample the drive sees a constant command u: x(σ) = x0 + uσ + (v0 − u)τ(1 −
    e^{−σ/τ}) (Koren eq 12 integrated); the dense grid must follow it."""
    gain, period = 18.0, 0.015625
    model = ServoModel(gain, TAU, period)
    t, e, dt = model.step_error(substeps=16)
    f, g = model.closed_loop()
    state = np.zeros(2)
    for n in range(5):  # sample n's state, then its 16 sub-steps in closed form
        u = gain * (1 - state[0])
        sigma = np.arange(16) * dt
        x = state[0] + u * sigma + (state[1] - u) * TAU * (1 - np.exp(-sigma / TAU))
        assert np.max(np.abs(1 - x - e[16 * n:16 * (n + 1)])) < 1e-12
        state = f @ state + g[:, 0]


# -- poles, C_v, frequency response ----------------------------------------------------------

@pytest.mark.parametrize("delay", [0, 1, 2])
def test_delayed_ideal_drive_poles(delay):
    """z^d (z − 1) + KT = 0: the characteristic equation of K·T z^{−d}/(z − 1)."""
    gain, period = 40.0, 0.005
    model = ServoModel(gain, None, period, delay)
    coefficients = np.zeros(delay + 2)  # z^{d+1} − z^d + KT
    coefficients[0], coefficients[1] = 1.0, -1.0
    coefficients[-1] += gain * period
    expected = np.roots(coefficients)
    got = model.poles()
    assert len(got) == delay + 1
    for p in expected:
        assert np.min(np.abs(got - p)) < 1e-10


@pytest.mark.parametrize("period, delay", [(None, 0), (0.01, 0), (0.01, 1), (0.005, 3)])
def test_velocity_constant_is_the_gain(period, delay):
    """Koren eq 5: the following error of a unit ramp is 1/K, at the samples too."""
    tau = TAU if delay < 3 else None
    model = ServoModel(25.0, tau, period, delay)
    assert 1 / model.ramp_following_error() == pytest.approx(25.0, rel=1e-10)


def test_continuous_frequency_response_is_the_closed_form():
    """H(jω) = K/(K − τω² + jω)."""
    model = ServoModel(25.0, TAU)
    omega = np.logspace(-1, 4, 200)
    exact = 25.0 / (25.0 - TAU * omega**2 + 1j * omega)
    assert np.max(np.abs(model.complementary(omega) - exact) / np.abs(exact)) < 1e-12
    # Koren's optimum K = (1 + (ωτ)²)/(2τ): |H| = 1 exactly, no radial error
    w = 5.0
    k_opt = (1 + (w * TAU) ** 2) / (2 * TAU)
    assert ServoModel(k_opt, TAU).radial_error(0.008, 0.008 * w) < 1e-15


@pytest.mark.parametrize("gain, tau, period, delay", [(18.0, TAU, 0.015625, 0),
                                                      (40.0, None, 0.002, 1),
                                                      (30.0, TAU, 0.01, 1)])
def test_circle_test_in_time_matches_the_frequency_response(gain, tau, period, delay):
    """Two axes fed r cos ωt, r sin ωt at the samples settle, at the samples, on a circle of
    radius r|H(e^{jωT})| (the time-domain circle test against the frequency response)."""
    model = ServoModel(gain, tau, period, delay)
    radius, feed = 0.008, 0.04
    at_samples = radius + model.circle_test(radius, feed).deviation[::CIRCLE_SUBSTEPS]
    h = abs(model.complementary(feed / radius)[0])
    assert np.max(np.abs(at_samples / (radius * h) - 1)) < 1e-9
    simulated = float(np.mean(at_samples))
    assert model.radial_error(radius, feed) == pytest.approx(abs(simulated - radius), rel=1e-6, abs=1e-15)


# -- the validation block --------------------------------------------------------------------

def _result(gain=18.0, period=0.015625, iae=None):
    model = ServoModel(gain, TAU, period)
    zeta, wn = model.equivalent_pair()
    integrals = model.error_integrals()
    poles = model.poles()
    return {
        "tuned": {"position_gain": {"value": gain}, "sampling_period": {"value": period}},
        "spec": {"plant": {"type": "software_servo", "technique": "sampled_data",
                           "time_constant": TAU}},
        "metrics": {
            "iae": {"metric": "iae", "value": integrals["iae"] if iae is None else iae,
                    "unit": "m·s", "options": {"time": "absolute", "input": "step"}},
            "damping_ratio": {"metric": "damping_ratio", "value": zeta, "unit": "1",
                              "options": {}},
        },
        "stability": {"stable": True, "poles": [[p.real, p.imag] for p in poles]},
    }


def test_block_accepts_a_consistent_result():
    block = validate_result(_result())
    assert block["covered"] and block["ok"] is True
    assert {e["metric"] for e in block["entries"]} == {"iae", "damping_ratio", "poles", "stable"}
    assert warning_lines(block) == []


def test_block_flags_a_tampered_metric():
    good = validate_result(_result())["entries"][0]["validated"]
    block = validate_result(_result(iae=good * 1.01))
    assert block["ok"] is False
    [line] = warning_lines(block)
    assert line.startswith("warning: validation: iae(time=absolute,input=step) reported ")
    # IAE ≈ 0.055 m·s: the relative 1e-4 (trapezoid) sets the tolerance, not the scale
    # 1 m × t (t = 1/min|p| ≈ 0.04 s) × 1e-6
    row = block["entries"][0]
    assert row["tolerance"] == pytest.approx(1e-4 * row["validated"], rel=1e-12)
    assert (f"gap {row['gap']:.3g} m·s > tolerance {row['tolerance']:.3g} m·s "
            "(0.0001 × |value|)") in line


def test_block_of_an_uncovered_plant_says_why():
    data = _result()
    data["spec"]["plant"] = {"type": "linear_motor"}  # a plant type without a model
    block = validate_result(data)
    assert block["covered"] is False and block["ok"] is None and "linear_motor" in block["reason"]


def test_block_never_raises():
    data = _result()
    del data["tuned"]["sampling_period"]
    block = validate_result(data)
    assert block["ok"] is None and "KeyError" in block["error"]
    assert warning_lines(block)[-1].startswith("warning: validation: the validator failed")


def test_batch_row_fails_on_a_validation_gap():
    base = {"status": "optimal", "success": True, "constraints_satisfied": True,
            "message": "fine", "objective": 1.0}
    assert row_ok({**base, "validation_ok": True}) and row_ok({**base, "validation_ok": None})
    assert row_ok(base)  # rows of older summaries
    failed = {**base, "validation_ok": False}
    assert not row_ok(failed)
    reason, message = failure(failed)
    assert reason == "validation" and "re-simulation" in message


# -- Sato eq 7: decrease in radius of the interpolated circle -------------------------------

def test_sato_eq_7_table_2():
    """Sato Table 2 (a): r = 50 mm, ω = 1 rad/s, K_p = 40 1/s, Δt_p = 2 ms, one sample of
    delay, N = 24 (T = 2π/(24ω)): printed Δr = 297 µm (to the µm printed). And against
    eq 4's exact dead time L = 1.5Δt_p, |G| = |K e^{−Ls}/(s + K e^{−Ls})|: the sampled loop
    read at the samples differs from it by O((ωΔt_p)²) in 1 − |G| (4e-7 here), so 1e-5."""
    radius, feed, gain, dt = 0.05, 0.05, 40.0, 0.002
    interval = 2 * math.pi / 24
    model = ServoModel(gain, None, dt, 1)
    assert model.radius_decrease(radius, feed, interval) == pytest.approx(297e-6, abs=0.5e-6)
    s = 1j * feed / radius
    g4 = abs(gain * np.exp(-1.5 * dt * s) / (s + gain * np.exp(-1.5 * dt * s)))
    average = radius * math.sqrt(math.sin(interval) / interval)  # eq 3
    deficit = (model.radius_decrease(radius, feed, interval) - (radius - average)) / average
    assert deficit == pytest.approx(1 - g4, rel=1e-5)


def test_the_step_responses_orbit_by_doubling_is_the_plain_recurrence():
    """software_servo's dense step response takes x, Mx, M²x, ... by doubling (log2 N
    matrix products, issue 15); it is the sample-by-sample recurrence up to rounding, for a
    stable affine loop and for the powers' first rows (an integrator: |λ| = 1, growing)."""
    from feedtune.validate.software_servo import _first_rows, _orbit

    rng = np.random.default_rng(7)
    f = rng.normal(size=(3, 3))
    f *= 0.95 / np.max(np.abs(np.linalg.eigvals(f)))
    affine = np.eye(4)
    affine[:3, :3], affine[:3, 3] = f, rng.normal(size=3)
    x, plain = np.array([0.0, 0.0, 0.0, 1.0]), []
    for _ in range(301):  # not a power of two: the last doubling is cut
        plain.append(x)
        x = affine @ x
    assert np.max(np.abs(_orbit(affine, np.eye(4)[3], 301) - plain)) <= 1e-13 * np.max(np.abs(plain))
    drive = np.array([[1.0, 0.01, 0.0], [0.0, 0.9, 0.1], [0.0, 0.0, 1.0]])  # integrator, lag, hold
    power, rows = np.eye(3), []
    for _ in range(256):
        rows.append(power[0])
        power = power @ drive
    assert np.max(np.abs(_first_rows(drive, 256) - rows)) <= 1e-13 * np.max(np.abs(rows))


def test_open_loop_at_one_frequency_is_the_grids_value_without_rebuilding_the_drive(monkeypatch):
    """brentq and bounded Brent ask for L at one ω at a time (≈ 66 calls a batch spec): the
    drive's matrices and its ZOH are built once per model, and L at one ω is the grid's
    value at that ω to the bit (the same LAPACK solve per frequency)."""
    from feedtune.validate.software_servo import ServoModel

    for delay, tau in ((0, 0.02), (2, 0.02), (1, None)):
        model = ServoModel(40.0, tau, 1 / 64, delay)
        grid = np.geomspace(0.1, math.pi * 64, 57)
        on_grid = model.open_loop(grid)
        monkeypatch.setattr(ServoModel, "drive_matrices", lambda self: pytest.fail("rebuilt"))
        monkeypatch.setattr(ServoModel, "zoh", lambda self, step: pytest.fail("rebuilt"))
        for i in (0, 20, 56):
            assert model.open_loop(float(grid[i]))[0] == on_grid[i]
        monkeypatch.undo()
