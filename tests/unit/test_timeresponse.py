"""feedtune.loops.timeresponse against closed forms and an independent evaluation.

Closed forms: first order e = e^{−at}; second order underdamped
e = e^{−ζωt}(cos ω_d t + ζ/√(1−ζ²) sin ω_d t) with ISE = (1 + 4ζ²)/(4ζω), overshoot
e^{−πζ/√(1−ζ²)} and ∫e = 2ζ/ω; a double pole e = (1 + at)e^{−at} (IAE 2/a, ITAE 3/a²,
ISE 5/(4a)); two poles δ apart, written with expm1 so that the closed form itself does not
cancel. Independent evaluation: y(t) = C expm(At) B of scipy's own realisation
(scipy.signal.tf2ss) and scipy.integrate.quad between crossings located on it.

Tolerances: the method is exact up to rounding (see the module docstring); 1e-12 relative
for integrals and 1e-13 absolute (unit-size responses) for values, unless stated.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.linalg import expm, matrix_balance
from scipy.optimize import brentq
from scipy.signal import tf2ss

from feedtune.loops.timeresponse import (DECAY, ResponseTooLongError, UnstableResponseError,
                                         Transient, load_response, reference_error,
                                         step_response)

LN_DECAY = math.log(1 / DECAY)


def second_order(zeta, omega):
    """(error numerator, denominator) of T = ω²/(s² + 2ζωs + ω²): S = s(s + 2ζω)/den."""
    return [1.0, 2 * zeta * omega, 0.0], [1.0, 2 * zeta * omega, omega**2]


def second_order_error(zeta, omega, t):
    sigma, wd = zeta * omega, omega * math.sqrt(1 - zeta**2)
    return np.exp(-sigma * t) * (np.cos(wd * t) + sigma / wd * np.sin(wd * t))


def independent(numerator, denominator):
    """t ↦ transient of the step response by expm on scipy's realisation (no clustering),
    balanced (a diagonal similarity: without it expm of a companion matrix whose
    coefficients span 18 decades is wrong in the 6th digit)."""
    num, den = np.asarray(numerator, float), np.asarray(denominator, float)
    steady = num[-1] / den[-1]
    padded = np.zeros(len(den))
    padded[len(den) - len(num):] = num
    q = (padded - steady * den)[:-1]
    a, b, c, _ = tf2ss(q, den)
    a, scaling = matrix_balance(a, permute=False)
    b, c = np.linalg.solve(scaling, b), c @ scaling
    return lambda t: float((c @ expm(a * t) @ b)[0, 0])


def quad_abs(f, crossings, end, weight=lambda t: 1.0):
    """∫|f|·weight over [0, end] by adaptive quadrature lobe by lobe."""
    points = [0.0, *crossings, end]
    total = 0.0
    for lo, hi in zip(points[:-1], points[1:]):
        value, _ = quad(lambda t: weight(t) * f(t), lo, hi, epsabs=0, epsrel=1e-13, limit=200)
        total += abs(value)
    return total


# -- first order -------------------------------------------------------------------------------

@pytest.mark.parametrize("a", [0.3, 3.0, 4000.0])
def test_first_order_step_and_ramp(a):
    step = reference_error([1.0, 0.0], [1.0, a], "step")  # S = s/(s + a): e = e^{−at}
    t = np.linspace(0, 10 / a, 101)
    np.testing.assert_allclose(step(t), np.exp(-a * t), rtol=0, atol=1e-15)
    assert step.steady == 0.0
    tr = step.transient
    assert tr.iae == pytest.approx(1 / a, rel=1e-14)
    assert tr.ise == pytest.approx(1 / (2 * a), rel=1e-14)
    assert tr.itae == pytest.approx(1 / a**2, rel=1e-14)
    assert tr.horizon == pytest.approx(LN_DECAY / a, rel=1e-14)  # 1e-12 of the initial size
    assert len(tr.crossings) == 0
    assert tr.last_exit(0.02) == pytest.approx(math.log(50) / a, rel=1e-14)
    # ramp: e = (1 − e^{−at})/a, e_ss = 1/a = 1/C_v, transient −e^{−at}/a
    ramp = reference_error([1.0, 0.0], [1.0, a], "ramp")
    assert ramp.steady == pytest.approx(1 / a, rel=1e-15)
    np.testing.assert_allclose(ramp(t), (1 - np.exp(-a * t)) / a, rtol=0, atol=1e-15 / a)
    assert ramp.transient.iae == pytest.approx(1 / a**2, rel=1e-14)


# -- second order ------------------------------------------------------------------------------

ZETAS = [0.02, 0.3, 0.7071, 0.95]


@pytest.mark.parametrize("zeta", ZETAS)
def test_second_order_underdamped_step_error(zeta):
    omega = 50.0
    response = reference_error(*second_order(zeta, omega))
    tr = response.transient
    t = np.linspace(0, tr.horizon, 20001)
    np.testing.assert_allclose(tr(t), second_order_error(zeta, omega, t), rtol=0, atol=1e-13)
    assert tr.ise == pytest.approx((1 + 4 * zeta**2) / (4 * zeta * omega), rel=1e-12)
    assert tr.integral() == pytest.approx(2 * zeta / omega, rel=1e-12)
    overshoot = math.exp(-math.pi * zeta / math.sqrt(1 - zeta**2))
    lowest, highest = response.extremes()
    assert -lowest == pytest.approx(overshoot, rel=1e-12)
    assert highest == pytest.approx(1.0, abs=1e-15)  # e(0) = 1

    # crossings: ω_d t − φ = π/2 + kπ with tan φ = ζ/√(1 − ζ²)
    wd, phi = omega * math.sqrt(1 - zeta**2), math.atan(zeta / math.sqrt(1 - zeta**2))
    exact = (np.pi / 2 + phi + np.pi * np.arange(len(tr.crossings))) / wd
    np.testing.assert_allclose(tr.crossings, exact, rtol=1e-13)
    assert exact[-1] + math.pi / wd > tr.span  # none missed (crossings are followed to span)

    # IAE and ITAE by independent quadrature lobe by lobe on the closed form
    f = lambda s: second_order_error(zeta, omega, s)  # noqa: E731
    iae = quad_abs(f, exact, tr.span)
    itae = quad_abs(f, exact, tr.span, weight=lambda s: s)
    assert tr.iae == pytest.approx(iae, rel=1e-12)
    assert tr.itae == pytest.approx(itae, rel=1e-12)


def test_second_order_overdamped_has_no_crossing():
    zeta, omega = 2.0, 10.0
    tr = reference_error(*second_order(zeta, omega)).transient
    assert len(tr.crossings) == 0
    assert tr.iae == pytest.approx(2 * zeta / omega, rel=1e-13)  # |e| = e
    a1, a0 = 2 * zeta * omega, omega**2
    assert tr.itae == pytest.approx((a1**2 - a0) / a0**2, rel=1e-13)


@pytest.mark.parametrize("zeta, band", [(0.3, 0.02), (0.05, 0.02), (0.7, 0.05), (0.3, 0.3)])
def test_second_order_settling_time(zeta, band):
    """Last time |e| = band, found independently: dense sampling of the closed form, Brent."""
    omega = 20.0
    tr = reference_error(*second_order(zeta, omega)).transient
    t = np.linspace(0, 60 / (zeta * omega), 2_000_001)
    outside = np.flatnonzero(np.abs(second_order_error(zeta, omega, t)) > band)[-1]
    sign = math.copysign(1, second_order_error(zeta, omega, t[outside]))
    exact = brentq(lambda s: second_order_error(zeta, omega, s) - sign * band,
                   t[outside], t[outside + 1], xtol=1e-15)
    assert tr.last_exit(band) == pytest.approx(exact, rel=1e-12)


def test_settling_never_outside_and_too_narrow():
    tr = step_response([1.0], [1.0, 1.0]).transient  # −e^{−t}
    assert tr.last_exit(2.0) == 0.0
    with pytest.raises(ValueError, match="below what the response resolves"):
        tr.last_exit(1e-20)
    with pytest.raises(ValueError):
        tr.last_exit(0.0)


# -- repeated and close poles --------------------------------------------------------------------

@pytest.mark.parametrize("a", [1.0, 250.0])
def test_double_pole(a):
    """T = a²/(s + a)²: e = (1 + at)e^{−at}; IAE 2/a, ISE 5/(4a), ITAE 3/a²."""
    tr = reference_error([1.0, 2 * a, 0.0], [1.0, 2 * a, a * a]).transient
    t = np.linspace(0, tr.horizon, 5001)
    np.testing.assert_allclose(tr(t), (1 + a * t) * np.exp(-a * t), rtol=0, atol=1e-14)
    assert tr.iae == pytest.approx(2 / a, rel=1e-13)
    assert tr.ise == pytest.approx(5 / (4 * a), rel=1e-12)
    assert tr.itae == pytest.approx(3 / a**2, rel=1e-13)
    # t e^{−at} still decays to 1e-12 of its peak by the horizon
    assert (1 + a * tr.horizon) * math.exp(-a * tr.horizon) <= 1.0001 * DECAY


def test_triple_pole():
    """1/(s + 1)³: y = 1 − (1 + t + t²/2)e^{−t}; ∫|y − 1| = 3, ∫t|y − 1| = 1 + 2 + 3 = 6."""
    r = step_response([1.0], [1.0, 3.0, 3.0, 1.0])
    t = np.linspace(0, r.horizon, 2001)
    np.testing.assert_allclose(r(t), 1 - (1 + t + t**2 / 2) * np.exp(-t), rtol=0, atol=1e-14)
    assert r.transient.iae == pytest.approx(3.0, rel=1e-13)
    assert r.transient.itae == pytest.approx(6.0, rel=1e-13)


@pytest.mark.parametrize("delta", [1e-9, 1e-7, 1e-4, 0.05, 0.5])
def test_close_real_poles(delta):
    """Poles a and b = a(1 + δ): e = e^{−at}(1 − a·expm1(−(b − a)t)/(b − a)), which does not
    cancel; ∫e = 1/a + 1/b; ISE = (ab + (a + b)²)/(2(a + b)ab); ∫te = ((a + b)² − ab)/(ab)²."""
    a = 10.0
    b = a * (1 + delta)
    tr = reference_error([1.0, a + b, 0.0], [1.0, a + b, a * b]).transient
    t = np.linspace(0, tr.horizon, 4001)
    d = b - a
    with np.errstate(invalid="ignore"):
        ratio = np.where(t > 0, np.expm1(-d * t) / np.where(t > 0, d, 1), -t)
    exact = np.exp(-a * t) * (1 - a * ratio)
    np.testing.assert_allclose(tr(t), exact, rtol=0, atol=2e-14)
    assert tr.iae == pytest.approx(1 / a + 1 / b, rel=1e-13)
    assert tr.itae == pytest.approx(((a + b) ** 2 - a * b) / (a * b) ** 2, rel=1e-13)
    assert tr.ise == pytest.approx((a * b + (a + b) ** 2) / (2 * (a + b) * a * b), rel=1e-12)


def test_repeated_complex_pair_against_independent_evaluation():
    """(s² + 2ζωs + ω²)² and a pair 1e-6 apart: against expm on scipy's realisation."""
    zeta, omega = 0.2, 30.0
    quad_ = np.array([1.0, 2 * zeta * omega, omega**2])
    for other in (quad_, np.array([1.0, 2 * zeta * omega * (1 + 1e-6), omega**2 * (1 + 1e-6)])):
        den = np.polymul(quad_, other)
        num = [den[-1]]
        r = step_response(num, den)
        f = independent(num, den)
        t = np.linspace(0, r.horizon, 301)
        np.testing.assert_allclose(r.transient(t), [f(s) for s in t], rtol=0, atol=1e-12)
        iae = quad_abs(f, r.transient.crossings, r.transient.span)
        assert r.transient.iae == pytest.approx(iae, rel=1e-12)


# -- higher order: Bhatia's compensated loop, K'_p = 80 ------------------------------------------

BHATIA_S = ([1.97529877e-14, 1.57283724e-10, 2.64851296e-07, 6.50176953e-05, 1.35768455e-02,
             1.47826611e+00, 5.80829416e+01, 3.01000326e+02, 0.0],
            [1.97529877e-14, 1.57283724e-10, 2.64851296e-07, 6.50176953e-05, 1.38435112e-02,
             1.76693170e+00, 1.22899410e+02, 3.97099551e+03, 2.40000260e+04])


def test_eighth_order_loop_against_independent_quadrature():
    """The example's loop (poles from −7.7 to −5713, a pair at −23 ± 172j; coefficients
    over 18 decades): values against expm, IAE/ITAE against quad between the crossings."""
    r = reference_error(*BHATIA_S)
    f = independent(*BHATIA_S)
    tr = r.transient
    t = np.linspace(0, 1.0, 401)
    np.testing.assert_allclose(tr(t), [f(s) for s in t], rtol=0, atol=1e-12)
    slowest = -np.max(np.roots(BHATIA_S[1]).real)  # ≈ 7.68 1/s, next to the zero at 7.5
    assert tr.horizon == pytest.approx(LN_DECAY / slowest, rel=1e-12)
    for c in tr.crossings:  # every crossing is a sign change of the independent evaluation
        assert f(c * (1 - 1e-9)) * f(c * (1 + 1e-9)) < 0
    assert tr.iae == pytest.approx(quad_abs(f, tr.crossings, tr.span), rel=1e-12)
    assert tr.itae == pytest.approx(quad_abs(f, tr.crossings, tr.span, lambda s: s), rel=1e-12)
    ise, _ = quad(lambda s: f(s) ** 2, 0, tr.span, epsabs=0, epsrel=1e-13, limit=500,
                  points=list(tr.crossings))
    assert tr.ise == pytest.approx(ise, rel=1e-12)


# -- ramp, load, refusals ------------------------------------------------------------------------

@pytest.mark.parametrize("gain, tau", [(30.0, 0.02), (80.0, 0.001)])
def test_ramp_steady_error_is_one_over_cv(gain, tau):
    """Type-1 loop K/(s(1 + τs)): S = s(τs + 1)/(τs² + s + K), e_ss = 1/C_v = 1/K."""
    ramp = reference_error([tau, 1.0, 0.0], [tau, 1.0, gain], "ramp")
    assert ramp.steady == pytest.approx(1 / gain, rel=1e-15)
    # at the horizon every mode is down to 1e-12 of its size (here ≤ 1.01/K)
    assert abs(ramp(ramp.horizon) - 1 / gain) < 1.01e-12 / gain
    assert ramp(0.0) == pytest.approx(0.0, abs=1e-16)


def test_load_step_of_a_type_1_loop():
    """θ/T_L = −1/(J s² + B s + K): a proportional position loop around an inertia; the load
    error settles at −1/K and the position starts at rest."""
    j, b, k = 0.01, 0.2, 50.0
    r = load_response([-1.0], [j, b, k])
    assert r.steady == pytest.approx(-1 / k, rel=1e-15)
    assert r(0.0) == pytest.approx(0.0, abs=1e-17)
    zeta = b / (2 * math.sqrt(j * k))
    low, high = r.extremes()
    assert low == pytest.approx(-(1 + math.exp(-math.pi * zeta / math.sqrt(1 - zeta**2))) / k,
                                rel=1e-12)
    assert high == 0.0


@pytest.mark.parametrize("den", [[1.0, -1.0], [1.0, 0.0, 4.0], [1.0, 1.0, 0.0], [1.0, -0.1, 9.0],
                                 [1.0, 2.0, 3.0, 10.0]])
def test_unstable_responses_are_refused(den):
    with pytest.raises(UnstableResponseError, match="does not settle"):
        step_response([1.0], den)


def test_ramp_of_a_type_0_loop_and_improper_transfers_are_refused():
    with pytest.raises(ValueError, match="type 0"):
        reference_error([1.0, 1.0], [1.0, 2.0], "ramp")
    with pytest.raises(ValueError, match="improper"):
        step_response([1.0, 0.0, 0.0], [1.0, 1.0])
    with pytest.raises(ValueError, match="finite"):
        step_response([np.nan], [1.0, 1.0])


def test_nearly_undamped_loop_is_refused_not_guessed():
    with pytest.raises(ResponseTooLongError, match="lightly damped"):
        step_response([1e6], [1.0, 1e-6, 1e6]).transient.iae


def test_proper_transfer_and_constant():
    """(s + 2)/(s + 1): y = 2 − e^{−t} (a jump at 0); a constant has no transient."""
    r = step_response([1.0, 2.0], [1.0, 1.0])
    assert r.steady == 2.0
    assert r(0.0) == pytest.approx(1.0, abs=1e-15)
    assert r.transient.iae == pytest.approx(1.0, rel=1e-14)
    c = step_response([3.0], [2.0])
    assert c.steady == 1.5 and c.transient.iae == 0.0 and c.transient.ise == 0.0


def test_a_turn_at_t_zero_to_rounding_ends_in_a_root_not_an_error():
    """Bhatia's tuned loop with σ_min ≥ 12 1/s (tests/reference/test_new_metrics.py, its
    transient at the tuned point of branch h-cold2): ẏ_tr(0) is 0 in exact arithmetic (its
    leading terms cancel) and 4.5e-15 in floating point, so the first grid interval holds
    a turn whose root lies at ≈ 1e-17 s. Brent's method, with its relative tolerance, needed
    108 iterations there and raised after 100; the root is now its last point. Its time is
    below 1e-15 s (1e-9 of the first grid step, 5.4e-7 s: at t = 0 for any response time),
    and the extremes hold the extrema found."""
    numerator = [1.230901003445581e-22, 5.799184310714309e-17, 6.487453931158783e-13,
                 -3.005847800905579e-08, -0.0003712781086787525, -0.12588491385464334,
                 -11.106562381082442, -221.15596407122715]
    denominator = [1.2270995283584186e-16, 5.781274296325391e-11, 7.109335488801282e-07,
                   0.00027420011371929304, 0.35233168623095956, 82.62582204874377,
                   19928.69080373988, 445035.6817335092, 2614991.331149016]
    transient = Transient(np.array(numerator), np.array(denominator))
    low, high = transient.extremes()
    times, values = transient._extrema
    assert 0 <= times[0] < 1e-15
    assert np.all(np.isfinite(values)) and low <= np.min(values) and high >= np.max(values)
    assert low < 0 < high
