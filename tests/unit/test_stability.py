"""feedtune.validate.stability.check_stability on hand-made matrices."""

from __future__ import annotations

import math

import numpy as np
import pytest

from feedtune.validate.stability import MARGIN, check_stability


def _rotation(radius: float, angle: float) -> np.ndarray:
    """Real 2×2 matrix with eigenvalues radius·e^{±j·angle}."""
    c, s = math.cos(angle), math.sin(angle)
    return radius * np.array([[c, -s], [s, c]])


# -- continuous ------------------------------------------------------------------------------

def test_continuous_stable():
    result = check_stability(np.array([[-1.0, 5.0], [0.0, -2.0]]), discrete=False)
    assert result["stable"] is True
    assert result["domain"] == "s"
    assert result["spectral_abscissa"] == pytest.approx(-1.0)
    assert result["poles"] == [[-2.0, 0.0], [-1.0, 0.0]]  # sorted by real part


def test_continuous_complex_pair_reported_as_re_im():
    a = np.array([[0.0, 1.0], [-25.0, -2.0]])  # s = −1 ± j√24
    result = check_stability(a, discrete=False)
    assert result["stable"] is True
    np.testing.assert_allclose(result["poles"], [[-1.0, -math.sqrt(24)], [-1.0, math.sqrt(24)]])


@pytest.mark.parametrize("matrix", [
    [[0.0, 1.0], [-1.0, 0.1]],        # growing oscillation
    [[0.5, 0.0], [0.0, -3.0]],        # one real pole in the right half plane
    [[0.0, 1.0], [-1.0, 0.0]],        # ±j: on the axis, not asymptotically stable
    [[0.0, 0.0], [0.0, -1.0]],        # an integrator
])
def test_continuous_unstable_or_marginal(matrix):
    result = check_stability(np.array(matrix), discrete=False)
    assert result["stable"] is False
    assert result["spectral_abscissa"] >= -MARGIN


def test_continuous_margin_is_relative_to_each_pole():
    """Re s < −MARGIN·|s| for every pole: a stiff but stable loop (poles from −0.013 to
    −1.8e7, as a lag-lead with τ12 = 100 s and τ = 1e-4 s gives) is stable; a pair too close
    to the jω axis for its own frequency (ζ = 1e-10) is not."""
    assert check_stability(np.diag([-0.013, -1.8e7]), discrete=False)["stable"] is True
    assert check_stability(np.diag([-1e-10, -1e3]), discrete=False)["stable"] is True
    assert check_stability(_rotation(1.0, math.pi / 2 + 1e-10), discrete=False)["stable"] is False
    assert check_stability(_rotation(1.0, math.pi / 2 + 1e-6), discrete=False)["stable"] is True


# -- discrete --------------------------------------------------------------------------------

def test_discrete_stable():
    result = check_stability(np.array([[0.5, 0.1], [0.0, -0.9]]), discrete=True)
    assert result["stable"] is True
    assert result["domain"] == "z"
    assert result["spectral_radius"] == pytest.approx(0.9)


@pytest.mark.parametrize("matrix, radius", [
    (_rotation(1.01, 0.3), 1.01),
    (_rotation(1.0, 0.3), 1.0),                     # on the unit circle
    (np.array([[-1.0, 0.0], [0.0, 0.2]]), 1.0),     # z = −1
    (np.array([[1.5, 0.0], [0.0, 0.2]]), 1.5),
])
def test_discrete_unstable_or_marginal(matrix, radius):
    result = check_stability(matrix, discrete=True)
    assert result["stable"] is False
    assert result["spectral_radius"] == pytest.approx(radius)


def test_discrete_and_continuous_differ_on_the_same_matrix():
    """diag(−2, −0.5) is Hurwitz but not Schur; diag(0.5, 0.2) is Schur but not Hurwitz."""
    assert check_stability(np.diag([-2.0, -0.5]), discrete=False)["stable"] is True
    assert check_stability(np.diag([-2.0, -0.5]), discrete=True)["stable"] is False
    assert check_stability(np.diag([0.5, 0.2]), discrete=False)["stable"] is False
    assert check_stability(np.diag([0.5, 0.2]), discrete=True)["stable"] is True


# -- non-finite input ------------------------------------------------------------------------

@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
@pytest.mark.parametrize("discrete", [False, True])
def test_non_finite_matrix_is_never_stable(bad, discrete):
    matrix = np.array([[-1.0, bad], [0.0, -0.5]])
    result = check_stability(matrix, discrete=discrete)
    assert result["stable"] is False
    assert result["domain"] == ("z" if discrete else "s")
    assert result["poles"] == []


def test_accepts_nested_lists():
    assert check_stability([[0.2]], discrete=True)["stable"] is True
    assert check_stability([[-0.2]], discrete=False)["stable"] is True
