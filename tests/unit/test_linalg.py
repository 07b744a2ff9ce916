"""feedtune.loops.linalg against numpy: characteristic polynomial, Hurwitz/Schur tests,
complex solve, polynomial roots.

Every check compares the CasADi-op helper with an independent numpy computation (roots,
eigenvalues, ``numpy.poly``, ``numpy.linalg.solve``) on seeded random data.
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from feedtune.loops import linalg
from expression_values import as_number, as_numbers


def _random_roots(rng, degree: int, stable: bool | None, *, discrete: bool = False) -> np.ndarray:
    """Real polynomial roots (conjugate pairs and reals) kept away from the stability boundary.

    ``stable`` True: all in the open left half plane (unit disc if discrete); False: at least
    one outside; None: anywhere. A 0.05 clearance from the boundary keeps the sign of every
    test unambiguous in double precision.
    """
    while True:
        roots: list[complex] = []
        while len(roots) < degree:
            pair = degree - len(roots) >= 2 and rng.random() < 0.5
            if discrete:
                radius = rng.uniform(0.05, 1.6)
                if abs(radius - 1) < 0.05:
                    continue
                if pair:
                    angle = rng.uniform(0.05, math.pi - 0.05)
                    roots += [radius * np.exp(1j * angle), radius * np.exp(-1j * angle)]
                else:
                    roots.append(radius * rng.choice([-1.0, 1.0]))
            else:
                real = rng.uniform(-3.0, 3.0)
                if abs(real) < 0.05:
                    continue
                if pair:
                    imag = rng.uniform(0.1, 3.0)
                    roots += [real + 1j * imag, real - 1j * imag]
                else:
                    roots.append(real)
        roots = np.array(roots, dtype=complex)
        inside = np.abs(roots) < 1 if discrete else roots.real < 0
        if stable is None or bool(np.all(inside)) == stable:
            return roots


# -- characteristic_polynomial --------------------------------------------------------------

@pytest.mark.parametrize("n", [1, 2, 3, 4, 5, 6])
def test_characteristic_polynomial_matches_numpy_poly(n):
    rng = np.random.default_rng(100 + n)
    for _ in range(5):
        a = rng.normal(size=(n, n))
        got = as_numbers(linalg.characteristic_polynomial(ca.DM(a)))
        expected = np.poly(a)
        assert got.shape == (n + 1,)
        assert got[0] == 1.0
        # Faddeev–LeVerrier and numpy.poly (via eigenvalues) round differently; the coefficient
        # of λ^(n-k) scales like ‖A‖^k, so compare against that scale at 1e-10 (n ≤ 6, ‖A‖ ~ 3).
        scale = np.array([np.linalg.norm(a, 2) ** k for k in range(n + 1)])
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-10 * scale.max())


def test_characteristic_polynomial_symbolic_equals_numeric():
    """The same code on an MX symbol, evaluated later, gives the numeric result."""
    rng = np.random.default_rng(7)
    a = rng.normal(size=(4, 4))
    sym = ca.MX.sym("a", 4, 4)
    f = ca.Function("poly", [sym], linalg.characteristic_polynomial(sym))
    got = np.array([float(v) for v in f(a)])
    np.testing.assert_allclose(got, as_numbers(linalg.characteristic_polynomial(ca.DM(a))), rtol=1e-13, atol=1e-13)


def test_characteristic_polynomial_roots_are_eigenvalues():
    rng = np.random.default_rng(11)
    a = rng.normal(size=(5, 5))
    roots = np.sort_complex(np.roots(as_numbers(linalg.characteristic_polynomial(ca.DM(a)))))
    eig = np.sort_complex(np.linalg.eigvals(a))
    np.testing.assert_allclose(roots, eig, atol=1e-8)  # simple, well separated eigenvalues


# -- hurwitz_conditions ---------------------------------------------------------------------

@pytest.mark.parametrize("degree", [1, 2, 3, 4, 5])
@pytest.mark.parametrize("stable", [True, False])
def test_hurwitz_conditions_positive_iff_roots_in_left_half_plane(degree, stable):
    rng = np.random.default_rng(1000 * degree + stable)
    for _ in range(40):
        roots = _random_roots(rng, degree, stable)
        # a leading coefficient of either sign: the conditions must not depend on it
        lead = rng.choice([-1.0, 1.0]) * rng.uniform(0.5, 2.0)
        coefficients = lead * np.real(np.poly(roots))
        conditions = as_numbers(linalg.hurwitz_conditions([ca.DM(c) for c in coefficients]))
        assert len(conditions) == max(degree, 2 * degree - 2)  # n coefficients + minors Δ2..Δ(n-1)
        assert bool(np.all(conditions > 0)) == stable, (roots, conditions)


def test_hurwitz_conditions_on_known_polynomials():
    # s² + 3s + 2 = (s+1)(s+2): stable; s³ + s² + s + 1 = (s+1)(s²+1): on the axis, Δ2 = 0
    assert np.all(as_numbers(linalg.hurwitz_conditions([1, 3, 2])) > 0)
    marginal = as_numbers(linalg.hurwitz_conditions([1.0, 1.0, 1.0, 1.0]))
    assert not np.all(marginal > 0)
    assert marginal[-1] == pytest.approx(0.0, abs=1e-15)
    # s³ + s² + 2s + 8: all coefficients positive yet unstable (Δ2 = 1·2 − 8 < 0)
    unstable = as_numbers(linalg.hurwitz_conditions([1.0, 1.0, 2.0, 8.0]))
    assert np.all(unstable[:3] > 0) and unstable[3] == pytest.approx(-6.0)


@pytest.mark.parametrize("kind", [ca.MX, ca.SX])
def test_symbolic_hurwitz_conditions_are_one_call_with_the_same_values(kind):
    """On MX symbols the conditions are one call of a Function built once per degree (not
    written out again per loop: 143 MX instructions written out at degree 8, since the
    minors come from Routh's array; thousands when they were a pivoted elimination each);
    on MX and SX they give the written-out conditions' numbers bit for bit, stable and
    unstable."""
    a = kind.sym("a", 9)
    conditions = linalg.hurwitz_conditions([a[i] for i in range(9)])
    function = ca.Function("conditions", [a], [ca.vertcat(*conditions)])
    written = ca.Function("written", [a], [ca.vertcat(*linalg._hurwitz_conditions(
        [a[i] for i in range(9)]))])
    if kind is ca.MX:
        operations = [function.instruction_id(k) for k in range(function.n_instructions())]
        assert operations.count(ca.OP_CALL) == 1
        assert function.n_instructions() < written.n_instructions()
    rng = np.random.default_rng(8)
    for stable in (True, False):
        coefficients = np.real(np.poly(_random_roots(rng, 8, stable)))
        got = np.asarray(function(coefficients), dtype=float).ravel()
        assert np.array_equal(got, np.asarray(written(coefficients), dtype=float).ravel())
        assert bool(np.all(got > 0)) == stable


def _hurwitz_matrix(coefficients: np.ndarray) -> np.ndarray:
    """H[i, j] = b_{2j − i} (1-based; b_0 the leading coefficient, 0 outside 0..n)."""
    n = len(coefficients) - 1
    return np.array([[coefficients[2 * j - i] if 0 <= 2 * j - i <= n else 0.0
                      for j in range(1, n + 1)] for i in range(1, n + 1)])


@pytest.mark.parametrize("degree", [3, 5, 8, 12])
def test_hurwitz_minors_equal_the_determinants(degree):
    """The minors Δ_2..Δ_{n−1} (from Routh's array) are numpy's determinants of the leading
    blocks of the Hurwitz matrix of lead·p, stable and unstable polynomials, roots over two
    decades. Tolerance: numpy's LU determinant is backward stable, its error a few ulps of
    the product of the rows' norms (the Hadamard bound); 1e-11 of that bound."""
    rng = np.random.default_rng(70 + degree)
    for stable in (True, False):
        for _ in range(10):
            roots = _random_roots(rng, degree, stable) * 10 ** rng.uniform(-1, 1)
            lead = rng.choice([-1.0, 1.0]) * rng.uniform(0.5, 2.0)
            coefficients = lead * np.real(np.poly(roots))
            minors = as_numbers(linalg.hurwitz_conditions(list(coefficients)))[degree:]
            h = _hurwitz_matrix(lead * coefficients)
            for k, minor in enumerate(minors, start=2):
                block = h[:k, :k]
                bound = np.prod(np.linalg.norm(block, axis=1))
                assert minor == pytest.approx(np.linalg.det(block), abs=1e-11 * bound)


@pytest.mark.parametrize("degree", [8, 12, 16])
def test_hurwitz_conditions_cost_grows_as_the_square_of_the_degree(degree):
    """Routh's array: about 2n² SX instructions (252 at degree 12), where a pivoted
    elimination per minor grew as n⁴ (11 599 at degree 12, built in 0.2–0.4 s of CPU in
    every fresh process). The bound 4n² leaves the constant free, not the order."""
    assert linalg._hurwitz_function(degree).n_instructions() < 4 * degree**2


@pytest.mark.parametrize("coefficients", [[1.0, 0.0, 0.0, 0.0, 1.0], [1.0, 0.0, 0.0, 0.0, 1.0, 0.0],
                                          [1.0, 0.0, 2.0, 0.0, 1.0], [1.0, 2.0, 1.0, 2.0, 1.0]])
def test_hurwitz_conditions_with_a_zero_pivot_say_not_stable(coefficients):
    """A zero in Routh's first column (s⁴ + 1, s⁵ + s, s⁴ + 2s² + 1, and a zero minor Δ_2 = 0
    of s⁴ + 2s³ + s² + 2s + 1) is a minor Δ_k = 0: never stable, and no condition is a
    number that says otherwise."""
    conditions = as_numbers(linalg.hurwitz_conditions(coefficients))
    assert not np.all(conditions > 0)
    assert not np.all(np.roots(coefficients).real < 0)


# -- bilinear_to_continuous -----------------------------------------------------------------

@pytest.mark.parametrize("degree", [1, 2, 3, 4, 5])
def test_bilinear_maps_unit_disc_to_left_half_plane(degree):
    """Schur stable (all |z| < 1) iff the transformed polynomial is Hurwitz."""
    rng = np.random.default_rng(500 + degree)
    outcomes = set()
    for _ in range(60):
        roots = _random_roots(rng, degree, None, discrete=True)
        lead = rng.choice([-1.0, 1.0]) * rng.uniform(0.5, 2.0)
        coefficients = lead * np.real(np.poly(roots))
        w_poly = linalg.bilinear_to_continuous([ca.DM(c) for c in coefficients])
        w_numbers = as_numbers(w_poly)
        schur = bool(np.all(np.abs(roots) < 1))
        outcomes.add(schur)
        assert bool(np.all(as_numbers(linalg.hurwitz_conditions(w_poly)) > 0)) == schur, roots
        # and each root maps as w = (z − 1)/(z + 1)
        expected_w = np.sort_complex((roots - 1) / (roots + 1))
        np.testing.assert_allclose(np.sort_complex(np.roots(w_numbers)), expected_w, atol=1e-6)
    assert outcomes == {True, False}  # both cases actually exercised


def test_bilinear_of_a_known_polynomial():
    # z − 0.5 → (1 + w) − 0.5(1 − w) = 1.5 w + 0.5 (highest power first)
    np.testing.assert_allclose(as_numbers(linalg.bilinear_to_continuous([1.0, -0.5])), [1.5, 0.5])
    # z² (double root at 0) → (1 + w)²
    np.testing.assert_allclose(as_numbers(linalg.bilinear_to_continuous([1.0, 0.0, 0.0])), [1.0, 2.0, 1.0])


# -- complex_solve --------------------------------------------------------------------------

@pytest.mark.parametrize("n", [1, 2, 3, 5])
def test_complex_solve_matches_numpy(n):
    rng = np.random.default_rng(30 + n)
    for _ in range(5):
        real = rng.normal(size=(n, n))
        imag = rng.normal(size=(n, n))
        rhs = rng.normal(size=(n, 1))
        expected = np.linalg.solve(real + 1j * imag, rhs)
        re, im = linalg.complex_solve(ca.DM(real), ca.DM(imag), ca.DM(rhs))
        # random complex systems of size ≤ 5 have condition numbers ≲ 1e3: 1e-10 is ample
        np.testing.assert_allclose(np.array(ca.evalf(re)), expected.real, rtol=1e-10, atol=1e-10)
        np.testing.assert_allclose(np.array(ca.evalf(im)), expected.imag, rtol=1e-10, atol=1e-10)


# -- roots (pure Python, for time and frequency scales) -------------------------------------

@pytest.mark.parametrize("seed", range(20))
def test_roots_are_numpys(seed):
    """Aberth–Ehrlich against numpy's companion-matrix eigenvalues on random polynomials of
    degree 1–8 with coefficients over ±4 decades: each root within 1e-8 of max(|root|, 1)
    (both are backward stable; a well-separated root moves by ~1e-14 here, 1e-8 leaves
    room for the closest pairs such draws make, and a scale needs far less)."""
    rng = np.random.default_rng(seed)
    p = list(rng.normal(size=rng.integers(2, 10)) * 10 ** rng.uniform(-2, 2))
    found, expected = np.array(linalg.roots(p)), np.roots(p)
    assert found.shape == expected.shape
    for r in expected:  # each of numpy's roots has one of ours nearby
        assert np.min(np.abs(found - r)) <= 1e-8 * max(abs(r), 1.0), (p, r, found)


@pytest.mark.parametrize("degree, decades", [(2, 40), (3, 30), (5, 15)])
def test_roots_decades_apart_each_to_its_own_magnitude(degree, decades):
    """Roots up to 2·decades apart in modulus (a drive's integrator-like slow pole beside a
    current loop's, in any unit): each found within 1e-11 of its own modulus. The slow one
    is what a settle time reads (1/|Re p|), so the scale is the root itself, not the largest.
    Aberth from one circle of the mean radius stopped short of such roots (up to 6e34
    relative on 87 of 3 000 quadratics, 2 × 40 decades); from the Newton polygon's circles
    every draw converges (measured ≤ 6e-12)."""
    rng = np.random.default_rng(degree)
    for _ in range(300):
        expected = 10 ** rng.uniform(-decades, decades, size=degree) * rng.choice([-1, 1], size=degree)
        found = np.array(linalg.roots(list(np.poly(expected))))
        for r in expected:
            assert np.min(np.abs(found - r)) <= 1e-11 * abs(r), (expected, found)


def test_roots_at_the_origin_are_exact_and_a_constant_has_none():
    """The README's two-mass drive: two integrators exact, the pair at −34.65 ± 1731.7j."""
    assert linalg.roots([2e-6, 1.386e-4, 6.0, 0.0, 0.0])[2:] == [0j, 0j]
    found = linalg.roots([2e-6, 1.386e-4, 6.0, 0.0, 0.0])[:2]
    assert all(abs(r.real + 34.65) <= 1e-9 * abs(r) for r in found)  # −ζω_n of the pair
    assert linalg.roots([3.0]) == []


def test_a_constant_term_that_underflows_once_made_monic_is_a_root_at_the_origin():
    """2z + 5e-324: the monic constant 5e-324/2 rounds to 0 (the smallest subnormal,
    halved). Its root, −2.5e-324, is 0 in floats; it raised IndexError (the Newton polygon
    had one point fewer than the degree), found by hypothesis through a spec's model in z
    (tests/unit/test_discrete_linear.py)."""
    assert linalg.roots([2.0, 5e-324]) == [0j]
    assert sorted(linalg.roots([1.0, 3.0, 5e-324]), key=abs) == [0j, pytest.approx(-3.0, abs=1e-15)]
    assert linalg.roots([0.0, 0.0]) == []


def test_pivoted_solve_is_numpys_on_symbols_and_numbers():
    """Two rows nearly parallel (the closed loop of a backward-Euler PI at T/T_i = 734) and
    a zero leading pivot: SX, MX and DM give LAPACK's answer to 1e-12 (normwise; measured
    2e-13); the gradient through the pivot choice is the solution's."""
    from feedtune.loops.linalg import pivoted_solve

    a = np.array([[-1.07869514e5, -8.52775484e4, 4.30886938e3],
                  [-2.11422248e5, -1.67143995e5, 8.44538398e3],
                  [-25.0, -19.7642354, 1.0]])
    b = np.array([[1.0], [2.0], [3.0]])
    expected = np.linalg.solve(a, b)

    def gap(x) -> float:  # normwise: the components span 3e-2 … 2e3
        return float(np.linalg.norm(np.array(x) - expected) / np.linalg.norm(expected))

    for kind in (ca.SX, ca.MX):
        m = kind.sym("m", 3, 3)
        assert gap(ca.Function("f", [m], [pivoted_solve(m, ca.DM(b))])(a)) <= 1e-12
    assert gap(pivoted_solve(ca.DM(a), ca.DM(b))) <= 1e-12
    zero_lead = np.array([[0.0, 1.0], [2.0, 3.0]])
    np.testing.assert_allclose(np.array(pivoted_solve(ca.DM(zero_lead), ca.DM([1.0, 1.0]))),
                               np.linalg.solve(zero_lead, [[1.0], [1.0]]), rtol=1e-15)
    # d(A⁻¹b)/dA_00 = −A⁻¹ e₀ e₀ᵀ A⁻¹ b
    m = ca.SX.sym("m", 3, 3)
    grad = ca.Function("g", [m], [ca.jacobian(pivoted_solve(m, ca.DM(b)), m[0, 0])])(a)
    inverse = np.linalg.inv(a)
    np.testing.assert_allclose(np.array(grad).ravel(), -inverse[:, 0] * (inverse[0] @ b)[0],
                               rtol=1e-6)


def test_a_companion_matrix_of_numbers_is_the_expressions_matrix():
    """Numbers are written straight into the companion matrix's layout: the same sparsity
    and the same entries, bit for bit (a signed zero included), as the matrix built on
    symbols and evaluated at those numbers."""
    rng = np.random.default_rng(11)
    for degree in range(1, 10):
        p = [float(c) for c in rng.normal(size=degree + 1) * 10.0 ** rng.uniform(-6, 6, degree + 1)]
        p[-1] = 0.0  # −0/p[0] or +0/p[0]: a zero's sign as the division gives it
        symbols = ca.SX.sym("p", degree + 1)
        expression = linalg.companion_matrix([symbols[i] for i in range(degree + 1)])
        evaluated = ca.Function("companion", [symbols], [expression])(p)
        numbers = linalg.companion_matrix(p)
        assert isinstance(numbers, ca.DM)
        assert numbers.shape == evaluated.shape
        np.testing.assert_array_equal(np.array(numbers), np.array(evaluated))
        assert [math.copysign(1, x) for x in np.array(numbers).ravel()] == \
            [math.copysign(1, x) for x in np.array(evaluated).ravel()]


def test_a_resolvent_on_numbers_is_the_graphs_value():
    """hessenberg_resolvent on numbers (numpy floats, a row of frequencies) returns the
    values its CasADi graph of the same operations gives at those numbers, bit for bit."""
    rng = np.random.default_rng(5)
    n = 6
    h, q = linalg.hessenberg(ca.DM(rng.normal(size=(n, n))))
    rhs, row = ca.DM(rng.normal(size=(n, 1))), ca.DM(rng.normal(size=(1, n)))
    wt = np.linspace(1e-3, math.pi, 7)
    shift_re, shift_im = -2 * np.sin(wt / 2) ** 2, np.sin(wt)
    re, im = linalg.hessenberg_resolvent(h, rhs, row, ca.DM(shift_re).T, ca.DM(shift_im).T)
    assert isinstance(re, ca.DM) and re.shape == (1, wt.size)
    x, y = ca.MX.sym("x", 1, wt.size), ca.MX.sym("y", 1, wt.size)
    graph = ca.Function("resolvent", [x, y], list(linalg.hessenberg_resolvent(
        ca.MX(h), ca.MX(rhs), ca.MX(row), x, y)))(shift_re, shift_im)
    np.testing.assert_array_equal(np.array(re), np.array(graph[0]))
    np.testing.assert_array_equal(np.array(im), np.array(graph[1]))
    # and a resolvent: row·(zI − H)⁻¹·rhs at one z
    z = complex(shift_re[3], shift_im[3]) + 1  # x = z − 1 is the shift
    exact = np.array(row) @ np.linalg.solve((z - 1) * np.eye(n) - np.array(h), np.array(rhs))
    assert complex(float(re[3]), float(im[3])) == pytest.approx(complex(exact.item()), rel=1e-12)
