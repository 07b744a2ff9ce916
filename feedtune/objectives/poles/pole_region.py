"""What the closed-loop pole metrics share (``decay_rate``, ``pole_damping``): the poles of
a loop of numbers in the s-plane, and polynomial tests for "every pole in a region".

A sampled loop's z-plane poles are mapped by s = ln(z)/T (principal branch), as MATLAB's
``damp`` does; a pole at z = 0 (a buffer sample of a computation delay) decays at once and
limits neither measure. The tests are the Hurwitz (Liénard–Chipart) conditions of
:func:`feedtune.loops.linalg.hurwitz_conditions`, as the loops' own stability conditions.
"""

from __future__ import annotations

import functools
import math

from feedtune.expr import Factors, PoleRegion, is_symbolic, to_float
from feedtune.lazy import ca, np
from feedtune.loops import linalg
from feedtune.loops.protocols import Loop


def s_plane_poles(matrix, discrete: bool, period: float | None):
    """Closed-loop poles [1/s] of a state matrix of numbers: its eigenvalues, or for a
    sampled loop ln(z)/T of every eigenvalue z ≠ 0, T = ``period`` [s]."""
    poles = np.linalg.eigvals(np.asarray(matrix, dtype=float)).astype(complex)
    if discrete:
        poles = np.log(poles[poles != 0]) / period
    return poles


def pole_region(loop: Loop, measure, conditions, lower: float, upper: float,
                factored=None) -> PoleRegion:
    """The :class:`~feedtune.expr.PoleRegion` of ``loop`` for ``measure(s-plane poles)``
    (numpy, a float), ``conditions(level)`` (or None) and the measure's range over stable
    loops [``lower``, ``upper``]; ``factored`` (or None) is ``factor_conditions(level, x)``
    for the factor form (:func:`factors`).

    The value comes from the numeric poles of the loop's state matrix (and period), so it
    agrees with the result's ``stability.poles``.
    """
    discrete = bool(loop.discrete)
    period = loop.period if discrete else 0.0
    numbers = loop.numeric_state_matrix()  # None for a loop of symbols
    if numbers is not None and not is_symbolic(period):  # each loop's numbers evaluated once
        n = numbers.shape[0]  # (the matrix's graph not read: a loop of numbers may not build it)
        numbers = np.append(numbers.ravel(order="F"), to_float(period))
        inputs = ca.DM(numbers)  # the column of numbers itself: no MX graph of constants
    else:
        matrix = loop.state_matrix
        n = matrix.shape[0]
        numbers = None
        inputs = ca.veccat(ca.vec(ca.MX(matrix)), ca.MX(period))

    def state(numbers):
        """The state matrix of the inputs' numbers (None if an entry is not finite)."""
        numbers = np.asarray(numbers, dtype=float).ravel()
        a = numbers[:n * n].reshape(n, n, order="F")  # ca.vec stacks columns
        return a if np.all(np.isfinite(a)) else None

    def of_numbers(numbers) -> float:
        numbers = np.asarray(numbers, dtype=float).ravel()  # numpy on a DM: CasADi 3.8 warns
        a = state(numbers)
        if a is None:
            return math.nan
        return float(measure(s_plane_poles(a, discrete, float(numbers[-1]))))

    if numbers is not None:  # a DM, not an MX constant: read without building a Function
        exact = ca.DM(of_numbers(numbers))
    elif conditions is None:  # reported only: never an expression the NLP would trust
        raise TypeError("this pole measure has no polynomial test on this loop: it is "
                        "evaluated on a loop of numbers only")
    else:
        exact = ca.MX(math.nan)
    return PoleRegion(conditions, inputs, of_numbers, exact, lower, upper,
                      None if factored is None else factors(loop, state, factored))


def decay_of(poles) -> float:
    """σ_min = min −Re p [1/s] (∞ without a pole: every mode dies at once)."""
    return float(np.min(-poles.real)) if poles.size else math.inf


def damping_of(poles) -> float:
    """ζ_min = min −Re p/|p| [1] (1 without a pole; 0 for a pole at the origin)."""
    if not poles.size:
        return 1.0
    size = np.abs(poles)
    zeta = np.where(size > 0, -poles.real / np.where(size > 0, size, 1.0), 0.0)
    return float(np.min(zeta))


def _balanced(poly: list) -> tuple[list, object]:
    """(p(ω0·x)/ω0^n, ω0) for a monic p (highest power first), ω0 = |p(0)|^(1/n) [rad/s]:
    roots of geometric mean size 1, so the tests' minors stay O(1)…O(10⁴) for loops whose
    corners span decades (as :func:`feedtune.loops.linalg.balanced_polynomial`)."""
    n = len(poly) - 1
    omega0 = ca.fabs(poly[-1]) ** (1.0 / n)
    return [c * omega0 ** (-i) for i, c in enumerate(poly)], omega0


def rotated_product(poly: list, angle) -> list:
    """Coefficients of p(e^{jα}x)·p(e^{−jα}x), α = ``angle`` [rad], highest power first.

    A real polynomial: the x^m coefficient is Σ_{k+l=m} b_k b_l cos((k − l)α) with b_k the
    coefficient of x^k. Its roots are the roots of p turned by ±α.
    """
    b = list(reversed(poly))  # ascending
    n = len(b) - 1
    out = []
    for m in range(2 * n + 1):
        total = 0
        for k in range(max(0, m - n), min(m, n) + 1):
            total = total + b[k] * b[m - k] * (ca.cos((2 * k - m) * angle) if 2 * k != m else 1)
        out.append(total)
    return list(reversed(out))


def decay_conditions(loop: Loop):
    """level σ [1/s] ↦ expressions all positive iff every closed-loop pole has −Re p > σ.

    Continuous: the Routh test (:func:`routh_column`) of p(s − σ), whose roots are the
    poles moved right by σ (written on the balanced polynomial, x = s/ω0). Sampled:
    |z| < e^{−σT}, the Routh test of p(r·z)/rⁿ with r = e^{−σT} mapped by
    z = (1 + w)/(1 − w), as the loop's settling conditions.

    Routh's entries rather than the Hurwitz minors of feedtune.loops.linalg (their
    products, which the loops' stability rows use): measured on Bhatia's example with all
    eight tunables free and σ_min ≥ 12 1/s, the minors (then a pivoted elimination each)
    ended at IPOPT's iteration limit (1428 iterations; their Liénard–Chipart subset:
    infeasible after 951), the Routh entries at the optimum in 114.
    """
    poly = loop.characteristic_polynomial
    if loop.discrete:
        period = loop.period

        def conditions(level):
            radius = ca.exp(-level * period)
            scaled = [c * radius ** (-k) for k, c in enumerate(poly)]
            return routh_column(linalg.bilinear_to_continuous(scaled))

        return conditions
    # built when the NLP first asks for a row (issue 15: a tuned design's report reads only
    # its poles; ≈ 0.3 ms of MX graph a report otherwise)
    basis = functools.cache(lambda: _balanced(poly))

    def conditions(level):
        balanced, omega0 = basis()
        return routh_column(linalg.taylor_shift(balanced, -level / omega0))

    return conditions


def routh_column(coefficients: list) -> list:
    """The Routh array's first column after the leading coefficient, each entry multiplied
    by that coefficient: all positive exactly when the polynomial (highest power first) is
    Hurwitz stable; entry k is Δ_k/Δ_{k−1} of the Hurwitz minors.

    O(n²) operations (used for the degree-2n product of :func:`damping_conditions`: 16
    for Bhatia's loop). For a generic polynomial only the last minor Δ_{n−1} (a pair on
    the boundary) or a_0 (a real root) vanishes at the boundary, so every entry is smooth
    there; not for the rotated product, where several entries change sign at once
    (measured on Bhatia's eight-tunable drive at ζ_min = 0.290 against 0.3: entry 10 of 16
    negative, the same in exact rational arithmetic). A pivot that is exactly 0 (far
    outside) is replaced by the smallest normal number, so no row is NaN
    (:func:`feedtune.loops.linalg.routh_first_column`).
    """
    lead = coefficients[0]
    return [lead * r for r in linalg.routh_first_column(coefficients,
                                                        len(coefficients) - 1)]


def damping_conditions(loop: Loop):
    """level ζ [1] ↦ expressions all positive iff every closed-loop pole of a continuous
    loop has −Re p/|p| > ζ, or None for a sampled loop.

    A pole has damping above ζ when it lies within the angle arccos ζ of the negative real
    axis; turning every pole by ±α, α = arcsin ζ, keeps them all in the open left half
    plane exactly then. So the test is the Routh–Hurwitz test (:func:`routh_column`) of
    the real polynomial p(e^{jα}s)·p(e^{−jα}s) of degree 2n (on the balanced polynomial). For ζ = 0 it is
    p² (stability); real poles pass for every ζ < 1. A sampled loop's region ζ ≥ ζ0 is
    bounded by a logarithmic spiral in the z-plane, which no Schur test of a polynomial
    describes: there the metric is reported only.
    """
    if loop.discrete:
        return None
    poly = loop.characteristic_polynomial
    basis = functools.cache(lambda: _balanced(poly))  # as decay_conditions'

    def conditions(level):
        # ζ ≥ 1 holds nowhere but on real poles: α = π/2 turns them onto the jω axis
        return routh_column(rotated_product(basis()[0], ca.asin(ca.fmin(level, 1))))

    return conditions


# -- the factor form: p(s) = ∏(s² + a_i s + b_i)·(s + c), coefficients matched (Vieta) --------

def paired_roots(roots) -> tuple[list[tuple[complex, complex]], float | None]:
    """The real factors of a real polynomial with roots ``roots``: pairs (r1, r2) of
    quadratic factors (each complex root with its conjugate, then the real roots sorted
    and paired with a neighbour) and the real root of the linear factor (odd count) or
    None. With an odd count of real roots, the one left alone is the one that makes the
    pairs' summed gaps |r1 − r2| least."""
    roots = np.asarray(roots, dtype=complex)
    upper = roots[roots.imag > 0]
    real = np.sort(roots[roots.imag == 0].real)
    single = None
    if real.size % 2:
        gap = [np.sum(np.abs(np.diff(np.delete(real, k))[::2])) for k in range(0, real.size, 2)]
        k = 2 * int(np.argmin(gap))
        single, real = float(real[k]), np.delete(real, k)
    pairs = [(r, np.conj(r)) for r in upper] + [(complex(real[k]), complex(real[k + 1]))
                                                 for k in range(0, real.size, 2)]
    return pairs, single


def factor_start(roots) -> tuple[np.ndarray, np.ndarray]:
    """(x, magnitudes): x = (a_1, b_1, …, a_m, b_m[, c]) of the factors s² + a s + b of
    each pair (a = −(r1 + r2), b = r1·r2) and s + c (c = −r) of :func:`paired_roots`;
    each magnitude the size of its coefficient (the pair's largest |r| for a, its square
    for b, |c|; 1 where that is 0)."""
    pairs, single = paired_roots(roots)
    x, size = [], []
    for r1, r2 in pairs:
        m = max(abs(r1), abs(r2)) or 1.0
        x += [-(r1 + r2).real, (r1 * r2).real]
        size += [m, m * m]
    if single is not None:
        x.append(-single)
        size.append(abs(single) or 1.0)
    return np.array(x, dtype=float), np.array(size, dtype=float)


def split_factors(x, degree: int) -> tuple[list[tuple], object]:
    """([(a_i, b_i)], c or None) of the variables x for a polynomial of ``degree``."""
    quadratic = [(x[2 * i], x[2 * i + 1]) for i in range(degree // 2)]
    return quadratic, (x[degree - 1] if degree % 2 else None)


def product(x, degree: int, size=lambda v: v) -> list:
    """Coefficients (highest power first, monic) of ∏(s² + a_i s + b_i)·(s + c) for the
    factor variables x, each coefficient taken through ``size`` first (``ca.fabs``: the
    sum of |terms| of each coefficient, its natural magnitude)."""
    quadratic, linear = split_factors(x, degree)
    out = [1]
    for factor in [[1, size(a), size(b)] for a, b in quadratic] + (
            [] if linear is None else [[1, size(linear)]]):
        out = linalg.poly_mul(out, factor)
    return out


def factors(loop: Loop, state, conditions) -> Factors:
    """The :class:`~feedtune.expr.Factors` of ``loop``'s characteristic polynomial:
    continuous loops on the frequency-balanced polynomial in x = s/ω0 (:func:`_balanced`,
    roots of geometric mean size 1), sampled loops on the polynomial in z. ``state`` maps
    the region's input numbers to the state matrix (None where not finite);
    ``conditions(level, quadratic, linear, omega0, period)`` gives the factor rows (ω0
    [rad/s] the balance frequency, 1 on a sampled loop; the period T [s], None on a
    continuous loop)."""
    discrete = bool(loop.discrete)
    poly = loop.characteristic_polynomial
    degree = len(poly) - 1
    if discrete:
        basis, period = (lambda: (poly, 1.0)), loop.period
    else:
        basis, period = functools.cache(lambda: _balanced(poly)), None

    def start(numbers):
        a = state(numbers)
        if a is None:
            return np.full(degree, math.nan), np.ones(degree)
        roots = np.linalg.eigvals(a).astype(complex)
        if not discrete:  # x = s/ω0, ω0 = |p(0)|^(1/n), the roots' geometric mean size
            roots = roots / math.exp(np.mean(np.log(np.abs(roots)))) if np.all(roots) else roots
        return factor_start(roots)

    def matching(x):
        return list(zip((t - c for t, c in zip(basis()[0][1:], product(x, degree)[1:])),
                        product(x, degree, ca.fabs)[1:]))

    return Factors(degree, start, matching,
                   lambda level, x: conditions(level, *split_factors(x, degree), basis()[1],
                                               period))


def damping_factor_conditions(level, quadratic, linear, omega0, period) -> list:
    """Expressions all positive iff every root of every factor has damping −Re r/|r| >
    ``level`` ζ [1] (continuous loops): s² + a s + b has its roots' ζ ≥ ζ0 exactly when
    a > 0, b > 0 and a² ≥ 4ζ0²b (complex roots: ζ = a/(2√b); real ones, both negative,
    have ζ = 1 and meet it already), s + c when c > 0. Invariant under s = ω0·x."""
    rows = [e for a, b in quadratic for e in (a, b, a * a - 4 * level * level * b)]
    return rows + ([] if linear is None else [linear])


def decay_factor_conditions(level, quadratic, linear, omega0, period) -> list:
    """Expressions all positive iff every root of every factor has decay rate > ``level``
    σ [1/s]. Continuous (x = s/ω0, σ' = σ/ω0): s² + a s + b shifted by σ' is x² + (a −
    2σ')x + (σ'² − aσ' + b), Hurwitz iff both coefficients are positive; s + c iff c > σ'.
    Sampled: |z| < r = e^{−σT}; z² + a z + b by Jury's conditions on z = r·w, r² − b > 0
    and r² ± a r + b > 0; z + c by r ∓ c > 0."""
    if period is not None:
        r = ca.exp(-level * period)
        rows = [e for a, b in quadratic for e in (r * r - b, r * r + a * r + b, r * r - a * r + b)]
        return rows + ([] if linear is None else [r - linear, r + linear])
    shift = level / omega0
    rows = [e for a, b in quadratic for e in (a - 2 * shift, shift * shift - a * shift + b)]
    return rows + ([] if linear is None else [linear - shift])
