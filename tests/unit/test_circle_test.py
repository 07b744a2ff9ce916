"""The exact circle test (circle_mean_deviation, circle_roughness, circularity) against
closed forms, limits and a brute-force simulation; the interpolation constraint metrics.

* A dead-beat loop (ideal drive, no delay, K = 1/Δt_p) moves along the polygon itself: its
  roughness and circularity are the sagitta r(1 − cos(ωT/2)), its mean deviation the
  chord's mean radius (closed form) minus r.
* q = 1 and Δt_p → 0: the mean deviation tends to the sampled loop's r(|G(e^{jωΔt})| − 1)
  and to the continuous loop's radial error; the ripple vanishes.
* An independent simulation: both axes stepped sample by sample from rest over many
  revolutions, the continuous path between samples from the matrix exponential of the
  plant on a fine sub-grid, statistics of the last, settled period.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from scipy.linalg import expm

from feedtune.objectives import METRICS
from feedtune.objectives.contour.circle import CircleOptions
from feedtune.objectives.contour.circle_test import circle_test
from feedtune.plants.software_servo import SoftwareServo, SoftwareServoParams
from expression_values import as_number
from test_sato_metrics import sato_loop

CIRCLE = CircleOptions(radius=0.05, feed=0.05)


def values(loop, options=CIRCLE):
    return {name: as_number(METRICS[name]().evaluate(loop, options))
            for name in ("circle_mean_deviation", "circle_roughness", "circularity")}


def chord_mean_radius(radius, angle):
    """∫₀¹ |P₀ + s(P₁ − P₀)| ds for a chord of a circle of ``radius`` spanning ``angle``."""
    h, c = radius * math.cos(angle / 2), 2 * radius * math.sin(angle / 2)
    u = c / 2
    return (u * math.hypot(h, u) + h * h * math.asinh(u / h)) / c


@pytest.mark.parametrize("q, interval", [(10, 0.02), (4, 0.2), (1, 0.3)])
def test_dead_beat_loop_draws_the_polygon(q, interval):
    period = interval / q
    loop = sato_loop(gain=1 / period, period=period, interval=interval, delay=0)
    got = values(loop)
    angle = CIRCLE.feed / CIRCLE.radius * interval
    sagitta = CIRCLE.radius * (1 - math.cos(angle / 2))
    assert got["circle_roughness"] == pytest.approx(sagitta, rel=1e-9)
    assert got["circularity"] == pytest.approx(sagitta, rel=1e-9)
    # the time mean on SUBDIVISIONS·q points per side (rectangle rule of a smooth chord)
    mean = chord_mean_radius(CIRCLE.radius, angle) - CIRCLE.radius
    assert got["circle_mean_deviation"] == pytest.approx(mean, abs=1e-4 * sagitta)


def test_q_one_small_period_tends_to_the_loop_gain():
    """T = Δt_p → 0: the polygon vanishes, the mean deviation is the sampled loop's radial
    error r(|G(e^{jωΔt})| − 1), the ripple is of order the tiny sagitta."""
    gain, period = 40.0, 1e-4
    loop = sato_loop(gain=gain, period=period, interval=period)
    got = values(loop)
    z = np.exp(1j * period)  # ω = 1 rad/s
    sampled = CIRCLE.radius * (abs(gain * period / (z * z - z + gain * period)) - 1)
    assert got["circle_mean_deviation"] == pytest.approx(sampled, rel=1e-4)
    assert got["circularity"] < 1e-3 * abs(sampled)


def test_fine_sampling_tends_to_the_continuous_loop():
    """Koren's drive K/(s(1 + sτ)): Δt_p → 0 without delay approaches the reference-pulse
    (continuous) loop's radial error r(|H(jω)| − 1)."""
    gain, tau, omega = 30.0, 0.02, 8.0
    circle = CircleOptions(radius=0.01, feed=0.01 * omega)
    s = 1j * omega
    continuous = circle.radius * (abs(gain / (tau * s * s + s + gain)) - 1)
    errors = []
    for period in (1e-3, 1e-4):
        loop = sato_loop(gain=gain, period=period, interval=period, delay=0, time_constant=tau)
        errors.append(abs(values(loop, circle)["circle_mean_deviation"] - continuous))
    assert errors[1] < 0.15 * errors[0]  # first order in Δt_p
    assert errors[1] < 0.03 * abs(continuous)


def simulate(loop, radius, feed, revolutions_samples, fine=64):
    """Brute force: both axes from rest, sample by sample; the plant between samples by its
    matrix exponential on ``fine`` points. Returns (time [s], radius [m]) on the fine grid."""
    gain = as_number(loop.gain)
    period = as_number(loop.period)
    interval = as_number(loop.interpolator.reference_interval)
    tau = loop.plant.time_constant
    delay = loop.delay
    omega = feed / radius
    # plant ẋ = A x + B u, states [position] or [position, velocity]
    if tau is None:
        a, b = np.zeros((1, 1)), np.ones((1, 1))
    else:
        a, b = np.array([[0, 1], [0, -1 / tau]]), np.array([[0], [1 / tau]])
    m = a.shape[0]
    big = np.zeros((m + 1, m + 1))
    big[:m, :m], big[:m, m:] = a, b
    sub = expm(big * period / fine)
    ad, bd = sub[:m, :m], sub[:m, m:]

    def reference(t):
        side = math.floor(t / interval + 1e-12)
        start = radius * np.exp(1j * omega * interval * side)
        end = radius * np.exp(1j * omega * interval * (side + 1))
        return start + (t / interval - side) * (end - start)

    # within a sample the state at its j-th fine point is ad^j x + (ad^(j-1) + … + 1) bd u:
    # ``fine`` steps of the exponential as one product per sample (the same recurrence)
    powers, drives = [np.eye(m)], [np.zeros(m)]
    for _ in range(fine):
        powers.append(ad @ powers[-1])
        drives.append(ad @ drives[-1] + bd[:, 0])
    position, position_drive = np.array(powers[:fine])[:, 0, :], np.array(drives[:fine])[:, 0]
    state = np.zeros(m, dtype=complex)
    pending = [0j] * delay
    path = []
    for k in range(revolutions_samples):
        command = gain * (reference(k * period) - state[0])
        pending.append(command)
        u = pending.pop(0)
        path.append(position @ state + position_drive * u)
        state = powers[fine] @ state + drives[fine] * u
    path = np.concatenate(path)
    times = np.arange(len(path)) * period / fine
    return times, np.abs(path)


@pytest.mark.parametrize("case", [
    dict(gain=40.0, period=0.002, interval=0.02, time_constant=None, delay=1),  # q = 10
    dict(gain=60.0, period=0.004, interval=0.026, time_constant=None, delay=1),  # q = 13/2
    dict(gain=25.0, period=0.005, interval=0.03, time_constant=0.02, delay=0),  # Koren
])
def test_against_brute_force_simulation(case):
    radius, feed = 0.02, 0.05  # ω = 2.5 rad/s
    loop = sato_loop(**case)
    test = circle_test(loop, radius, feed)
    q = Fraction(case["interval"] / case["period"]).limit_denominator(16)
    period = case["interval"] * q.denominator  # the steady state repeats after b sides
    samples = round(period / case["period"])
    total = samples * math.ceil(3000 / samples)
    times, r = simulate(loop, radius, feed, total)
    last = times >= times[-1] - period + 1e-12
    deviation = r[last] - radius
    ripple = np.max(deviation) - np.min(deviation)
    # the simulation's rectangle rule on 64 points per sample against the closed form
    # (ideal drive) or 16 points (lag): equal to 1e-4 of the ripple
    assert test.mean_deviation == pytest.approx(np.mean(deviation), abs=1e-4 * ripple)
    assert test.circularity == pytest.approx(ripple, rel=1e-3)
    assert test.roughness <= test.circularity + 1e-15


def test_unstable_loop_reports_infinity():
    loop = sato_loop(gain=900.0, period=0.002, interval=0.02)
    assert math.isinf(values(loop)["circularity"])


def test_supports_the_exact_sampled_loop_only():
    pade = sato_loop(model="pade")
    exact = sato_loop()
    for name in ("circle_mean_deviation", "circle_roughness", "circularity"):
        metric = METRICS[name]()
        assert metric.supports(exact) and not metric.supports(pade)
        assert not metric.optimisable(exact)


def test_interpolation_ratio_and_reference_interval():
    loop = sato_loop(period=0.002, interval=0.13)
    assert as_number(METRICS["interpolation_ratio"]().evaluate(loop, None)) == pytest.approx(65)
    assert as_number(METRICS["reference_interval"]().evaluate(loop, None)) == pytest.approx(0.13)
    plain = SoftwareServo(SoftwareServoParams(type="software_servo", technique="sampled_data",
                                              time_constant=0.02))
    box = {n: (t.min, t.max) for n, t in plain.tunables().items()}
    plain_loop = plain.loop({"position_gain": 30.0, "sampling_period": 0.005}, box)
    assert not METRICS["interpolation_ratio"]().supports(plain_loop)
