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
