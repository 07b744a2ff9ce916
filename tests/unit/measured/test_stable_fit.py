"""Stability of identified models above second order (feedtune.measured.fit): a_i ≥ 0 makes
1 + a_1 s + … + a_n s^n stable only up to n = 2, so a 4th-order fit of noisy data can come
out unstable; the fit then reflects the unstable poles, refits the numerator, and fits the
output error over stable second-order factors (Factors)."""

from __future__ import annotations

import numpy as np
import pytest

from feedtune.measured.data import FrequencyResponseData
from feedtune.measured.fit import (MIN_DAMPING, Factors, Structure, _output_error, band, fit,
                                   hurwitz, linear_fit, reflected)

#: a two-mass drive, velocity per volt through two modes, position integrates: G(s) =
#: K/(s (s²/ω1² + 2ζ1 s/ω1 + 1)(s²/ω2² + 2ζ2 s/ω2 + 1)); all four poles stable
K, MODES = 50.0, ((300.0, 0.02), (1200.0, 0.01))
#: measured 10-800 rad/s: the second mode lies beyond the band, its damping undetermined
OMEGA = np.logspace(1, np.log10(800.0), 40)
#: complex noise of 10 % of |G| in each part; seed 7 (and 11 of the first 12) makes the fit unstable
NOISE, SEED = 0.1, 7
STRUCTURE = Structure(zeros=0, poles=4, integrators=1, dead_time=False, positive_gain=True)


def _data() -> FrequencyResponseData:
    a = np.array([1.0])
    for omega, zeta in MODES:
        a = np.polymul(a, [1 / omega**2, 2 * zeta / omega, 1.0])
    s = 1j * OMEGA
    rng = np.random.default_rng(SEED)
    noise = NOISE * (rng.standard_normal(len(OMEGA)) + 1j * rng.standard_normal(len(OMEGA)))
    return FrequencyResponseData(OMEGA, K / (s * np.polyval(a, s)) * (1 + noise), None,
                                 input_unit="V", output_unit="rad", source="two-mass")


def _poles(model) -> np.ndarray:
    return np.polynomial.polynomial.polyroots(model.denominator)


def test_without_the_stabilising_step_the_fit_of_a_stable_plant_is_unstable():
    """The precondition: the sign-constrained linear fit and the output-error fit in the
    coefficients from it both have a pole pair in the right half-plane (Re ≈ +5.3 rad/s,
    measured) although every a_i ≥ 0."""
    data = [_data()]
    low, high = band(data)
    omega0 = float(np.sqrt(low * high))
    x0, solves = linear_fit(data, STRUCTURE, omega0, None)
    assert np.all(x0[:4] >= 0) and not hurwitz(x0[:4])
    plain = _output_error(data, STRUCTURE, omega0, x0, solves, None)
    assert _poles(plain.model).real.max() > 0


def test_the_fit_of_a_stable_plant_is_stable_and_matches_the_data():
    """With the stabilising step every pole has Re ≤ −ζ_min·|p| (the factored fit's
    bound), the in-band mode is found (300 rad/s within 2 %: the band holds it with 10 %
    noise on 40 points), and the relative error is the noise's (10 %·√2 RMS: a model that
    explains the plant leaves only the noise)."""
    result = fit([_data()], STRUCTURE)
    poles = _poles(result.model)
    assert np.all(poles.real <= -MIN_DAMPING * np.abs(poles) * (1 - 1e-9))
    assert "reflected" in result.stabilisation and "factors" in result.stabilisation
    assert np.min(np.abs(np.abs(poles) - 300.0)) < 0.02 * 300.0
    assert result.nrmse[0] < NOISE * np.sqrt(2)


@pytest.mark.parametrize("roots", [
    [-1.0, -2.0, -3.0 + 4.0j, -3.0 - 4.0j],
    [-0.5 + 2.0j, -0.5 - 2.0j, -1.0 + 0.1j, -1.0 - 0.1j, -7.0],
    [-2.0, -5.0, -9.0],
])
def test_factors_reproduce_a_stable_denominator_and_their_jacobian(roots):
    """of → coefficients is the identity on stable denominators (1e-12: a few roundings of
    numbers of size 1), and jacobian agrees with central differences (1e-6 relative: the
    step's truncation error, h² with h = 1e-5)."""
    poly = np.polynomial.polynomial.polyfromroots(roots).real
    a = poly[1:] / poly[0]
    factors = Factors(len(roots))
    f = factors.of(a)
    np.testing.assert_allclose(factors.coefficients(f), a, rtol=1e-12, atol=1e-12)
    h = 1e-5
    numeric = np.column_stack([(factors.coefficients(f + h * e) - factors.coefficients(f - h * e))
                               / (2 * h) for e in np.eye(len(f))])
    np.testing.assert_allclose(factors.jacobian(f), numeric, rtol=1e-6, atol=1e-9)


def test_reflection_keeps_the_magnitude_and_makes_the_denominator_stable():
    """−r̄ for each right-half-plane root r: |a(jω)| is the same at every ω (1e-12
    relative), every root is in the left half-plane."""
    poly = np.polynomial.polynomial.polyfromroots([1.0 + 3.0j, 1.0 - 3.0j, -2.0, 0.5]).real
    a = poly[1:] / poly[0]
    assert not hurwitz(a)
    b = reflected(a)
    assert hurwitz(b)
    s = 1j * np.logspace(-2, 2, 50)
    np.testing.assert_allclose(np.abs(np.polynomial.polynomial.polyval(s, np.r_[1.0, b])),
                               np.abs(np.polynomial.polynomial.polyval(s, np.r_[1.0, a])),
                               rtol=1e-12)
