"""feedtune.validate.integrals: exact integrals of a piecewise-linear error, sign changes
included, against adaptive quadrature of the same interpolant."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad

from feedtune.validate.integrals import error_integrals


def _quadrature(t: np.ndarray, e: np.ndarray) -> dict[str, float]:
    """The integrals of np.interp(t, e) by quad, piece by piece, split at each zero."""
    def f(x):
        return float(np.interp(x, t, e))

    totals = {"iae": 0.0, "ise": 0.0, "itae": 0.0}
    for i in range(t.size - 1):
        points = [t[i], t[i + 1]]
        if e[i] * e[i + 1] < 0:
            points.insert(1, t[i] + (t[i + 1] - t[i]) * e[i] / (e[i] - e[i + 1]))
        for a, b in zip(points[:-1], points[1:]):
            totals["iae"] += quad(lambda x: abs(f(x)), a, b, epsabs=0, epsrel=1e-13)[0]
            totals["ise"] += quad(lambda x: f(x) ** 2, a, b, epsabs=0, epsrel=1e-13)[0]
            totals["itae"] += quad(lambda x: x * abs(f(x)), a, b, epsabs=0, epsrel=1e-13)[0]
    return totals


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_piecewise_linear_error_with_sign_changes_matches_quadrature(seed):
    """An uneven grid, a decaying ringing error (many sign changes, a zero on a grid point,
    equal-sign runs): closed forms and quadrature agree to rounding (quad at 1e-13). ITAE
    was 4e-5 off here: t|e| was integrated by its trapezoid where e keeps its sign."""
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.5e-3, 2e-3, 400))  # [s]
    e = np.exp(-t / 0.1) * np.cos(2 * np.pi * t / 0.05 + seed)  # [m]
    e[37] = 0.0
    got, expected = error_integrals(t, e), _quadrature(t, e)
    assert any(e[:-1] * e[1:] < 0)
    for name in ("iae", "ise", "itae"):
        assert got[name] == pytest.approx(expected[name], rel=1e-11), name


def test_one_sign_piece_of_t_times_e_is_exact():
    """e = t on [0, 1] s: ∫t|e| = 1/3 m·s² (the trapezoid of t|e| gave 1/2)."""
    got = error_integrals(np.array([0.0, 1.0]), np.array([0.0, 1.0]))
    assert got["itae"] == pytest.approx(1 / 3, rel=1e-15)
    assert got["iae"] == pytest.approx(1 / 2, rel=1e-15)
    assert got["ise"] == pytest.approx(1 / 3, rel=1e-15)


def test_one_crossing_piece_is_two_triangles():
    """e from 1 to −3 over [2, 6] s: zero at t = 3; ∫|e| = (1·1 + 3·3)/2 = 5 m·s,
    ∫e² = 4·(1 + 9 − 3)/3 = 28/3 m²·s, ∫t|e| = ∫₂³ t(3 − t) dt + ∫₃⁶ t(t − 3) dt = 7/6 + 45/2."""
    got = error_integrals(np.array([2.0, 6.0]), np.array([1.0, -3.0]))
    assert got["iae"] == pytest.approx(5.0, rel=1e-15)
    assert got["ise"] == pytest.approx(28 / 3, rel=1e-15)
    assert got["itae"] == pytest.approx(7 / 6 + 45 / 2, rel=1e-15)


@pytest.mark.parametrize("names", [("iae",), ("ise",), ("itae",), ("iae", "itae")])
def test_the_integrals_asked_for_alone_are_the_same_floats(names):
    """``names``: only those integrals are computed and returned, each the very float of
    the three computed together (the same operations: the validator asks for one)."""
    rng = np.random.default_rng(3)
    t = np.cumsum(rng.uniform(0.5e-3, 2e-3, 400))  # [s]
    e = np.exp(-t / 0.1) * np.cos(2 * np.pi * t / 0.05)  # [m], many sign changes
    every = error_integrals(t, e)
    assert error_integrals(t, e, names) == {name: every[name] for name in names}


@pytest.mark.parametrize("size", [1, 2, 1000, 3 * (1 << 15) + 17])
def test_the_ise_in_chunks_is_the_whole_arrays_formula_to_the_bit(size):
    """The ISE's pieces computed a chunk at a time (``integrals.CHUNK``, so a 31-million-point
    grid needs no array-sized temporaries) are the whole arrays' expression, bit for bit,
    across chunk boundaries too (sizes below, at and beyond a few chunks)."""
    rng = np.random.default_rng(size)
    t = np.cumsum(rng.uniform(1e-4, 1e-3, size))  # [s]
    e = rng.standard_normal(size)  # [m]
    e0, e1 = e[:-1], e[1:]
    whole = float(np.sum((e0 * e0 + e1 * e1 + e0 * e1) * np.diff(t))) / 3
    assert error_integrals(t, e, ("ise",))["ise"] == whole
