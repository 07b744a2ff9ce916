"""The validator's sampled open loop at one frequency (brentq's and Brent's calls) against
the formula L(e^{jωT}) = K·z^{−d}·C(zI − Φ)⁻¹Γ solved as a stack of one system: the same
LAPACK solve, so the same bits (the validator's values are pinned to their bits by
tests/unit/test_validator_golden.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from feedtune.validate.software_servo import ServoModel


def _stacked(model: ServoModel, omega: float) -> np.ndarray:
    """The formula with the right-hand side broadcast over a stack of one matrix."""
    phi, gamma = model.zoh(model.period)
    c = model.drive_matrices()[2][0]
    z = np.exp(1j * np.array([omega]) * model.period)
    resolvent = z[:, None, None] * np.eye(phi.shape[0]) - phi
    rhs = np.broadcast_to(gamma, (1, *gamma.shape))
    return model.gain * z ** (-model.delay) * (np.linalg.solve(resolvent, rhs)[:, :, 0] @ c)


@pytest.mark.parametrize("gain, tau, period, delay", [
    (17.98, 0.02, 1 / 64, 0),  # Koren's sampled-data example
    (40.0, 0.01, 1 / 128, 1),  # one sample of computation delay
    (5.0, 0.05, 1 / 32, 0),
])
def test_one_frequency_is_the_stacked_solve_to_the_bit(gain, tau, period, delay):
    model = ServoModel(gain, tau, period, delay=delay)
    for omega in np.geomspace(0.1, math.pi / period, 37):
        one = model.open_loop(float(omega))
        assert one.shape == (1,)
        assert one.tobytes() == _stacked(model, float(omega)).tobytes()


def test_a_grid_still_solves_every_frequency():
    model = ServoModel(17.98, 0.02, 1 / 64)
    grid = np.geomspace(0.1, math.pi * 64, 11)
    values = model.open_loop(grid)
    assert values.shape == (11,)
    # each entry the formula at its own ω (a relative scale of the response itself)
    for omega, value in zip(grid, values):
        assert abs(value - _stacked(model, float(omega))[0]) <= 1e-14 * abs(value)


#: loops of every branch of ServoModel.open_loop_at: no delay, one and two samples of
#: computation delay (two takes the array's own power), Sato's ideal drive 1/s, and the
#: continuous reference-pulse loop
ONE_FREQUENCY_LOOPS = [
    (17.98, 0.02, 1 / 64, 0),
    (40.0, 0.01, 1 / 128, 1),
    (20.0, 0.02, 1 / 256, 2),
    (30.0, None, 1 / 100, 0),
    (30.0, None, 1 / 100, 1),
    (50.0, 0.01, None, 0),
]


def _frequencies(model: ServoModel, count: int = 400) -> np.ndarray:
    """ω [rad/s] spread over the band the refinements search: from 1e-3 rad/s to π/T (a
    continuous loop: to 1e4 rad/s), at random points so that no grid's rounding is special."""
    top = math.pi / model.period if model.sampled else 1e4
    rng = np.random.default_rng(15)
    return np.exp(rng.uniform(math.log(1e-3), math.log(top), count))


@pytest.mark.parametrize("gain, tau, period, delay", ONE_FREQUENCY_LOOPS)
def test_open_loop_at_one_frequency_is_the_arrays_value_to_the_bit(gain, tau, period, delay):
    """open_loop_at (numpy's scalar type, no arrays) is open_loop(ω)[0] bit for bit: the
    refinements' values, and so every validated value they give, are those of the
    array path they replace."""
    model = ServoModel(gain, tau, period, delay=delay)
    for omega in _frequencies(model):
        one = model.open_loop_at(float(omega))
        assert type(one) is np.complex128
        assert one.tobytes() == model.open_loop(float(omega))[0].tobytes()


@pytest.mark.parametrize("gain, tau, period, delay", ONE_FREQUENCY_LOOPS)
def test_the_blu_criterion_at_one_radius_is_the_arrays_value_to_the_bit(gain, tau, period,
                                                                        delay):
    """criterion_at (the minimum radius's brentq and Brent) is blu_criterion([r])[0] bit for
    bit, over radii from 1e-5 to 10 m at Koren's V_m = 0.02 m/s."""
    model = ServoModel(gain, tau, period, delay=delay, blu=1e-6, max_velocity=0.02)
    radii = 0.02 / _frequencies(model)
    for radius in radii:
        assert model.criterion_at(float(radius)) == model.blu_criterion(float(radius))[0]


@pytest.mark.parametrize("gain, tau, period, delay", ONE_FREQUENCY_LOOPS)
def test_the_frequency_metrics_one_frequency_response_is_lapacks_to_rounding(gain, tau, period,
                                                                             delay):
    """frequency_response_at (the frequency metrics' refinements: Cramer's rule in Python's
    complex numbers) is (L, H) of the LAPACK solve to 1e-14 of |L| and of |H| (relative
    scales of the responses themselves, neither of which vanishes on the unit circle), and
    |H/H(1)|² at one ω is the grid's formula on an array of that ω to 1e-14 of itself."""
    from feedtune.validate import sampled_frequency

    model = ServoModel(gain, tau, period, delay=delay)
    for omega in _frequencies(model):
        lo, closed = model.frequency_response_at(float(omega))
        assert type(lo) is complex and type(closed) is complex
        assert abs(lo - model.open_loop(float(omega))[0]) <= 1e-14 * abs(lo)
        assert abs(closed - model.complementary(float(omega))[0]) <= 1e-14 * abs(closed)
        if model.sampled:
            value = sampled_frequency._gain_squared(model, float(omega),
                                                    sampled_frequency._scan(model)[3])
            grid = (np.abs(model.complementary(float(omega)) / model.dc_gain()) ** 2)[0]
            assert abs(value - grid) <= 1e-14 * value


@pytest.mark.parametrize("states", [1, 2, 3])
def test_the_one_frequency_solve_is_numpys_to_the_bit(states):
    """open_loop_at's solve (LAPACK's zgesv through scipy) gives np.linalg.solve's bits on
    random complex systems of the drive's sizes, −Φ + z·I as the resolvent is built (real
    entries, z of modulus 1 on the diagonal) and general complex ones, over 16 decades of
    scale: numpy and scipy each ship their own LAPACK, so this pins them to agree."""
    from feedtune.validate.software_servo import _solve_resolvent

    rng = np.random.default_rng(1979)
    for trial in range(3000):
        scale = 10.0 ** rng.uniform(-8, 8, size=(states, states))
        matrix = (rng.standard_normal((states, states))
                  + 1j * rng.standard_normal((states, states))) * scale
        if trial % 2:
            matrix = (-matrix.real).astype(complex)
            matrix[np.diag_indices(states)] += np.exp(1j * rng.uniform(0, math.pi))
        rhs = (rng.standard_normal((states, 1)) * 10.0 ** rng.uniform(-6, 2)).astype(complex)
        assert _solve_resolvent(matrix, rhs).tobytes() == np.linalg.solve(matrix, rhs).tobytes()


def test_the_one_frequency_solve_refuses_a_singular_matrix_as_numpy_does():
    from feedtune.validate.software_servo import _solve_resolvent

    singular = np.array([[1.0, 2.0], [2.0, 4.0]], dtype=complex)
    rhs = np.ones((2, 1), dtype=complex)
    with pytest.raises(np.linalg.LinAlgError, match="Singular matrix"):
        np.linalg.solve(singular, rhs)
    with pytest.raises(np.linalg.LinAlgError, match="Singular matrix"):
        _solve_resolvent(singular, rhs)
