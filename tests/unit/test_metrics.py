"""Each metric's formula on numeric loops built by SoftwareServo, against numpy or the paper.

Paper formulas are typed here from Koren 1979 (Y. Koren, ASME J. Eng. Ind., 1979):
eq 1 f_m = V_m/BLU; eq 9 ζ = 1/(2√(Kτ)); eq 10 ω_n = √(K/τ); eq 26 f_m/f_s; eq 28
e_r/r = (L/2)(ωT)² (+ an (ωT)⁴ term); eq 29 L = (Kτ(T/τ + 2) − 1)/(KT)²; eq 32
r/BLU = L(T f_m)²; eq 33 r/BLU = (2Kτ − 1)(f_m/K)²; eq 37
e_r/r = 1 − 1/√(1 + (2ζω/ω_n)² − 2(ω/ω_n)² + (ω/ω_n)⁴); eq 38 e_r/r = 1 − 1/√(1 + 4(ωτ)⁴).
"""

from __future__ import annotations

import functools
import math

import casadi as ca
import numpy as np
import pytest
from scipy.linalg import expm
from scipy.optimize import brentq

from feedtune.expr import Magnitude
from feedtune.objectives import METRICS
from feedtune.plants.software_servo import SoftwareServo, SoftwareServoParams

TAU, BLU, V_M = 0.02, 5e-6, 0.04  # Koren's design example: τ = 20 ms, BLU = 5 µm, V_m = 40 mm/s
F_M = V_M / BLU  # eq 1: 8000 pulses/s


def _value(x) -> float:
    """A metric's value as a float; a Magnitude keeps its sign (the tuner takes |·|)."""
    if isinstance(x, Magnitude):
        x = x.expr
    if isinstance(x, (int, float)):
        return float(x)
    return float(ca.evalf(ca.MX(x)))


def _loop(technique, gain, period=None, delay=0, counter_bits=8):
    params = SoftwareServoParams(type="software_servo", technique=technique, time_constant=TAU,
                                 blu=BLU, max_velocity=V_M, computation_delay=delay,
                                 counter_bits=counter_bits)
    values = {"position_gain": gain}
    box = {"position_gain": (gain / 2, gain * 2)}
    if period is not None:
        values["sampling_period"] = period
        box["sampling_period"] = (period / 2, period * 2)
    return SoftwareServo(params).loop(values, box)


def _metric(name, **options):
    cls = METRICS[name]
    return cls(), cls.Options(**options)


def _h_continuous(gain, omega):
    """Koren eq 7: H(jω) = K/(τ(jω)² + jω + K)."""
    s = 1j * omega
    return gain / (TAU * s**2 + s + gain)


@functools.lru_cache(maxsize=None)
def _van_loan(period: float) -> np.ndarray:
    """expm([[A, B], [0, 0]] T) of Koren's plant: Φ = e[:2, :2], Γ = e[:2, 2]; once per
    period (the radius scans below evaluate H at thousands of ω). Read only."""
    augmented = np.array([[0.0, 1.0, 0.0], [0.0, -1 / TAU, 1 / TAU], [0.0, 0.0, 0.0]])
    return expm(augmented * period)


def _h_sampled(gain, period, delay, omega):
    """H(e^{jωT}) = G/(1 + G), G(z) = K z^{−d}[1 0](zI − Φ)⁻¹Γ, (Φ, Γ) by Van Loan expm."""
    e = _van_loan(period)
    z = np.exp(1j * omega * period)
    g = gain * (np.array([1.0, 0.0]) @ np.linalg.solve(z * np.eye(2) - e[:2, :2], e[:2, 2])) * z ** (-delay)
    return g / (1 + g)


def _koren_l(gain, period):
    """Koren eq 29."""
    return (gain * TAU * (period / TAU + 2) - 1) / (gain * period) ** 2


CIRCLES = [(0.008, 0.04), (0.05, 0.04), (0.002, 0.01)]  # (radius [m], feed [m/s])

# |H| comes from a real 2n×2n linear solve (linalg.complex_solve) whose condition number for
# these loops is up to ≈1e4 (entries K/τ against ω): |H| is good to ≈1e-12 absolute (measured
# ≤ 5e-12 relative on H). The radial error r(|H| − 1) therefore carries ≈r·1e-12 absolute;
# relative accuracy is meaningless when |H| − 1 ~ 1e-7. This bounds what tests may demand.
H_TOL = 2e-11
CONTINUOUS_GAINS = [10.0, 25.0, 100.0]
SAMPLED = [(18.0, 1 / 64, 0), (30.0, 1 / 64, 0), (60.0, 0.005, 0), (10.0, 0.01, 1), (5.0, 0.01, 2)]


# -- radial error ----------------------------------------------------------------------------

@pytest.mark.parametrize("radius, feed", CIRCLES)
@pytest.mark.parametrize("gain", CONTINUOUS_GAINS)
def test_radial_error_continuous_is_r_times_abs_h_minus_one(gain, radius, feed):
    metric, options = _metric("radial_error", radius=radius, feed=feed)
    value = metric.evaluate(_loop("reference_pulse", gain), options)
    assert isinstance(value, Magnitude)  # |·| is left to the tuner (epigraph)
    expected = radius * (abs(_h_continuous(gain, feed / radius)) - 1)
    assert _value(value) == pytest.approx(expected, rel=1e-9, abs=H_TOL * radius)


@pytest.mark.parametrize("radius, feed", CIRCLES)
@pytest.mark.parametrize("gain, period, delay", SAMPLED)
def test_radial_error_sampled_is_r_times_abs_h_minus_one(gain, period, delay, radius, feed):
    metric, options = _metric("radial_error", radius=radius, feed=feed)
    value = metric.evaluate(_loop("sampled_data", gain, period, delay), options)
    assert isinstance(value, Magnitude)
    expected = radius * (abs(_h_sampled(gain, period, delay, feed / radius)) - 1)
    assert _value(value) == pytest.approx(expected, rel=1e-9, abs=H_TOL * radius)


@pytest.mark.parametrize("radius, feed", CIRCLES)
@pytest.mark.parametrize("gain", CONTINUOUS_GAINS)
def test_radial_error_koren_continuous_is_eq37(gain, radius, feed):
    metric, options = _metric("radial_error_koren", radius=radius, feed=feed)
    loop = _loop("reference_pulse", gain)
    value = metric.evaluate(loop, options)
    assert isinstance(value, Magnitude)
    omega = feed / radius
    zeta = 1 / (2 * math.sqrt(gain * TAU))  # eq 9
    omega_n = math.sqrt(gain / TAU)  # eq 10
    ratio = omega / omega_n
    eq37 = radius * (1 - 1 / math.sqrt(1 + (2 * zeta * ratio) ** 2 - 2 * ratio**2 + ratio**4))
    # same closed form, evaluated in a different order: rounding on a difference 1 − 1/√(·)
    assert abs(_value(value)) == pytest.approx(abs(eq37), rel=1e-9, abs=1e-18)
    # eq 37 is exact for the continuous loop, so it equals the exact metric in magnitude
    # (opposite sign conventions: docs/errata.md)
    exact = _value(METRICS["radial_error"]().evaluate(loop, options))
    assert abs(_value(value)) == pytest.approx(abs(exact), rel=1e-9, abs=H_TOL * radius)


@pytest.mark.parametrize("omega_tau", [0.01, 0.1, 0.3])
def test_radial_error_koren_at_half_over_tau_is_eq38(omega_tau):
    """K = 1/(2τ) (eq 36): eq 37 reduces to eq 38, e_r/r = 1 − 1/√(1 + 4(ωτ)⁴)."""
    radius = 0.01
    feed = omega_tau / TAU * radius
    metric, options = _metric("radial_error_koren", radius=radius, feed=feed)
    value = _value(metric.evaluate(_loop("reference_pulse", 1 / (2 * TAU)), options))
    eq38 = radius * (1 - 1 / math.sqrt(1 + 4 * omega_tau**4))
    assert abs(value) == pytest.approx(eq38, rel=1e-9)  # algebraically identical


@pytest.mark.parametrize("radius, feed", CIRCLES)
@pytest.mark.parametrize("gain, period", [(18.0, 1 / 64), (30.0, 1 / 64), (60.0, 0.005), (5.0, 0.02)])
def test_radial_error_koren_sampled_is_eq28_leading_term(gain, period, radius, feed):
    metric, options = _metric("radial_error_koren", radius=radius, feed=feed)
    value = metric.evaluate(_loop("sampled_data", gain, period), options)
    assert isinstance(value, Magnitude)
    omega = feed / radius
    eq28 = radius * _koren_l(gain, period) / 2 * (omega * period) ** 2
    assert abs(_value(value)) == pytest.approx(abs(eq28), rel=1e-12)  # same formula


def test_eq28_leading_term_matches_exact_radial_error_at_small_omega_t():
    """docs/errata.md: K = 30, T = 1/64 s, ω = 0.5 rad/s: |H| − 1 = +9.288e-5 = (L/2)(ωT)²."""
    gain, period, omega = 30.0, 1 / 64, 0.5
    options = dict(radius=0.01, feed=0.01 * omega)
    loop = _loop("sampled_data", gain, period)
    exact = _value(METRICS["radial_error"]().evaluate(loop, METRICS["radial_error"].Options(**options)))
    koren = _value(METRICS["radial_error_koren"]().evaluate(loop, METRICS["radial_error_koren"].Options(**options)))
    assert exact / 0.01 == pytest.approx(9.288e-5, rel=1e-3)  # 4 printed digits
    # the neglected (N/2)(ωT)⁴ term is (ωT)² ≈ 6e-5 relative to the leading one
    assert koren == pytest.approx(exact, rel=1e-3)


# -- drive ratios ----------------------------------------------------------------------------

@pytest.mark.parametrize("period", [1e-3, 1 / 64, 0.1])
def test_encoder_and_sampling_ratios(period):
    loop = _loop("sampled_data", 18.0, period)
    assert _value(METRICS["encoder_ratio"]().evaluate(loop, None)) == pytest.approx(F_M * period, rel=1e-14)
    assert _value(METRICS["sampling_ratio"]().evaluate(loop, None)) == pytest.approx(period / TAU, rel=1e-14)


@pytest.mark.parametrize("bits", [2, 8, 12, 16])
def test_counter_utilisation(bits):
    """Pulses per sample at V_m, f_m·T, over the counter's 2^(bits−1) (one sign bit)."""
    period = 1 / 64
    loop = _loop("sampled_data", 18.0, period, counter_bits=bits)
    got = _value(METRICS["counter_utilisation"]().evaluate(loop, None))
    assert got == pytest.approx(F_M * period / 2 ** (bits - 1), rel=1e-14)
    if bits == 8:
        assert got == pytest.approx(125 / 128)  # Koren's example: 125 pulses in a 128-count counter


# -- minimum radius --------------------------------------------------------------------------

@pytest.mark.parametrize("gain", [5.0, 25.0, 0.567 / TAU, 100.0])
def test_min_radius_koren_continuous_is_eq33(gain):
    loop = _loop("reference_pulse", gain)
    got = _value(METRICS["min_radius_koren"]().evaluate(loop, None))
    assert got == pytest.approx(BLU * (2 * gain * TAU - 1) * (F_M / gain) ** 2, rel=1e-12)


@pytest.mark.parametrize("gain, period", [(18.0, 1 / 64), (30.0, 1 / 64), (60.0, 0.005), (5.0, 0.02)])
def test_min_radius_koren_sampled_is_eq32(gain, period):
    loop = _loop("sampled_data", gain, period)
    got = _value(METRICS["min_radius_koren"]().evaluate(loop, None))
    assert got == pytest.approx(BLU * _koren_l(gain, period) * (period * F_M) ** 2, rel=1e-12)


def test_min_radius_koren_eq32_tends_to_eq33_as_t_vanishes():
    """Koren: eq 33 is eq 32 with T = 0."""
    gain = 40.0
    continuous = _value(METRICS["min_radius_koren"]().evaluate(_loop("reference_pulse", gain), None))
    sampled = _value(METRICS["min_radius_koren"]().evaluate(_loop("sampled_data", gain, 1e-7), None))
    assert sampled == pytest.approx(continuous, rel=1e-5)  # O(T/τ) = 5e-6 apart


def _largest_root(radial_error):
    """Largest r with radial_error(r) = BLU/2: scan down from 10⁷ m, then brentq."""
    def excess(r):
        return radial_error(r) - BLU / 2

    radii = np.geomspace(1e7, 1e-6, 4000)
    assert excess(radii[0]) < 0
    for previous, radius in zip(radii[:-1], radii[1:]):
        if excess(radius) > 0:
            return brentq(excess, radius, previous, xtol=1e-300, rtol=1e-15)
    raise AssertionError("no root")


def _continuous_radial_error(gain):
    """r·| |H| − 1 | without cancellation: |H|² − 1 = ω²(2Kτ − 1 − τ²ω²)/D, D = (K − τω²)² + ω²."""
    def error(r):
        omega = V_M / r
        d = (gain - TAU * omega**2) ** 2 + omega**2
        h = gain / math.sqrt(d)
        return r * abs(omega**2 * (2 * gain * TAU - 1 - TAU**2 * omega**2) / (d * (h + 1)))

    return error


def _min_radius_tolerance(radius: float) -> float:
    """At the root |H| − 1 = BLU/(2r) and the error falls like 1/r or faster, so an error
    H_TOL in |H| moves r by at most H_TOL·2r/BLU relative (1e-9 floor for the root-finder)."""
    return 1e-9 + H_TOL * 2 * radius / BLU


# K = 0.1 (the default lower bound) gives r = 31.9 km, K = 1 r = 307 m; K = 25 is Koren's
# design example (6.89 mm, docs/errata.md)
@pytest.mark.parametrize("gain", [0.1, 1.0, 5.0, 25.0, 100.0, 1000.0])
def test_min_radius_continuous_is_largest_root(gain):
    got = _value(METRICS["min_radius"]().evaluate(_loop("reference_pulse", gain), None))
    expected = _largest_root(_continuous_radial_error(gain))
    assert got == pytest.approx(expected, rel=_min_radius_tolerance(expected))


@pytest.mark.parametrize("gain, period, delay", SAMPLED + [(2.0, 0.3, 0), (100.0, 1e-3, 0)])
def test_min_radius_sampled_is_largest_root(gain, period, delay):
    got = _value(METRICS["min_radius"]().evaluate(_loop("sampled_data", gain, period, delay), None))
    expected = _largest_root(lambda r: r * abs(abs(_h_sampled(gain, period, delay, V_M / r)) - 1))
    assert got == pytest.approx(expected, rel=_min_radius_tolerance(expected))


# -- second-order metrics and time normalisation -------------------------------------------------

def test_damping_and_natural_frequency_metrics_read_the_loop():
    loop = _loop("reference_pulse", 30.0)
    assert _value(METRICS["damping_ratio"]().evaluate(loop, None)) == pytest.approx(
        1 / (2 * math.sqrt(30.0 * TAU)), rel=1e-14)  # eq 9
    assert _value(METRICS["natural_frequency"]().evaluate(loop, None)) == pytest.approx(
        math.sqrt(30.0 / TAU), rel=1e-14)  # eq 10


@pytest.mark.parametrize("technique, period", [("reference_pulse", None), ("sampled_data", 1 / 64)])
def test_natural_time_weights_step_integrals_by_powers_of_omega_n(technique, period):
    """∫|e| d(ω_n t) = ω_n·IAE; ∫(ω_n t)|e| d(ω_n t) = ω_n²·ITAE; ISE likewise ω_n·ISE."""
    loop = _loop(technique, 18.0, period)
    omega_n = _value(loop.natural_frequency())
    for name, power in (("iae", 1), ("ise", 1), ("itae", 2)):
        metric = METRICS[name]()
        absolute = _value(metric.evaluate(loop, metric.Options(time="absolute")))
        natural = _value(metric.evaluate(loop, metric.Options(time="natural")))
        assert natural == pytest.approx(omega_n**power * absolute, rel=1e-13)


def test_supports_follow_the_loop_kind():
    continuous = _loop("reference_pulse", 25.0)
    sampled = _loop("sampled_data", 18.0, 1 / 64)
    delayed = _loop("sampled_data", 10.0, 1 / 64, delay=1)
    circle = dict(radius=0.01, feed=0.02)
    for name in ("encoder_ratio", "sampling_ratio", "counter_utilisation"):  # need a period
        metric = METRICS[name]()
        assert not metric.supports(continuous) and metric.supports(sampled) and metric.supports(delayed)
    for name in ("damping_ratio", "natural_frequency"):  # need a pole pair
        metric = METRICS[name]()
        assert metric.supports(continuous) and metric.supports(sampled) and not metric.supports(delayed)
    for name, options in (("radial_error_koren", circle), ("min_radius_koren", {})):  # eqs 28–33: no delay
        metric, opts = _metric(name, **options)
        assert metric.supports(continuous, opts) and metric.supports(sampled, opts)
        assert not metric.supports(delayed, opts)
    iae = METRICS["iae"]()
    assert iae.supports(delayed, iae.Options(time="absolute"))
    assert not iae.supports(delayed, iae.Options(time="natural"))  # ω_n needs second order


@pytest.mark.parametrize("gain", [10.0, 40.0])
@pytest.mark.parametrize("omega", [1e-4, 1e-2, 1.0, 30.0])
def test_radius_gain_excess_continuous_matches_closed_form_without_cancellation(gain, omega):
    """|H| − 1 for K/(τs² + s + K): 1/|H|² = 1 + x, x = ((1 − 2Kτ)ω² + τ²ω⁴)/K² (from eq 37),
    so |H| − 1 = −x/(√(1+x)(1 + √(1+x))), exact in floating point. At ω = 1e-4 rad/s the
    excess is ~1e-11 and a plain |H| − 1 keeps ~5 digits; 1e-9 relative is asked. (At
    K = 1/(2τ) the ω² term vanishes and |S|² − 2 Re S cancels too; that case would need
    the open loop, which Loops do not expose.)"""
    from feedtune.objectives.contour.circle import radius_gain_excess

    x = ((1 - 2 * gain * TAU) * omega**2 + TAU**2 * omega**4) / gain**2
    expected = -x / (math.sqrt(1 + x) * (1 + math.sqrt(1 + x)))
    loop = _loop("reference_pulse", gain)
    assert float(ca.evalf(radius_gain_excess(loop, omega))) == pytest.approx(expected, rel=1e-9, abs=0)


@pytest.mark.parametrize("gain, period", [(30.0, 1 / 64), (10.0, 0.01)])
def test_radius_gain_excess_sampled_tends_to_eq28_at_tiny_omega_t(gain, period):
    """Eq 28's leading term (L/2)(ωT)² is the exact |H| − 1 up to O((ωT)²) relative (the
    coefficient is ~30 here): at ωT = 1e-6 they agree to 1e-8, which needs |H| − 1
    (~1e-11) free of cancellation; a plain |H| − 1 keeps ~5 digits."""
    from feedtune.objectives.contour.circle import radius_gain_excess

    omega = 1e-6 / period
    loop = _loop("sampled_data", gain, period)
    expected = _koren_l(gain, period) / 2 * (omega * period) ** 2
    assert float(ca.evalf(radius_gain_excess(loop, omega))) == pytest.approx(expected, rel=1e-8, abs=0)


def test_min_radius_of_a_loop_of_numbers_scans_the_radii_once(monkeypatch):
    """The exact minimum radius evaluates the criterion over its grid of radii once (the
    radii above the largest failing one are read from that scan), then point by point for
    the refinements; the value is the scan's own."""
    import feedtune.objectives.contour.min_radius as min_radius

    from test_min_radius_screen import row_sizes

    sizes = row_sizes(monkeypatch)
    # every radius scanned: the screen (a structure's second evaluation on) evaluates a
    # subset with the same bits, tests/unit/test_min_radius_screen.py
    monkeypatch.setattr(min_radius, "_screened", lambda *args: None)
    got = _value(METRICS["min_radius"]().evaluate(_loop("sampled_data", 18.0, 1 / 64), None))
    assert [s for s in sizes if s > 1] == [min_radius.PER_DECADE_EXACT * min_radius.SPAN + 1]
    expected = _largest_root(lambda r: r * abs(abs(_h_sampled(18.0, 1 / 64, 0, V_M / r)) - 1))
    assert got == pytest.approx(expected, rel=_min_radius_tolerance(expected))
