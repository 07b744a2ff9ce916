"""Small linear-algebra helpers written in CasADi operations.

Every function here works on CasADi symbols (SX/MX) and on numbers (DM) alike, so the
same expression serves the NLP and the evaluation of a tuned design.
"""

from __future__ import annotations

import cmath
import math
import functools
import sys

from feedtune.lazy import ca, np


def characteristic_polynomial(matrix) -> list:
    """Monic characteristic polynomial det(λI − A), highest power first.

    Faddeev–LeVerrier recursion: exact in exact arithmetic, and well conditioned for the
    small (n ≤ 10) closed loops of feed drives.

    Returns
    -------
    list
        ``[1, c_{n-1}, ..., c_0]`` with ``det(λI − A) = λ^n + c_{n-1} λ^{n-1} + ... + c_0``.
    """
    n = matrix.shape[0]
    if isinstance(matrix, ca.DM) and matrix.sparsity().is_dense():
        return [ca.DM(c) for c in _characteristic_polynomial_of_floats(matrix.full().tolist())]
    coefficients = [ca.DM(1.0)]
    m_k = ca.DM.zeros(n, n)
    c_k = ca.DM(1.0)
    for k in range(1, n + 1):
        m_k = ca.mtimes(matrix, m_k) + c_k * ca.DM.eye(n)
        c_k = -ca.trace(ca.mtimes(matrix, m_k)) / k
        coefficients.append(c_k)
    return coefficients


def _characteristic_polynomial_of_floats(a: list) -> list:
    """:func:`characteristic_polynomial`'s recursion on a dense matrix of floats (rows of
    Python floats), operation for operation as CasADi does it on a dense DM (issue 15:
    ≈ 20 DM operations of ≈ 10-20 µs each on a 3 × 3 loop): each product entry summed
    from 0.0 over k ascending (``casadi_mtimes``), c·I added to every entry (0.0 off the
    diagonal, as a dense matrix plus the sparse identity is), the trace summed from 0.0;
    a scalar DM operation is the IEEE double operation Python's float does, so the same
    bits (signed zeros included)."""
    n = len(a)
    coefficients = [1.0]
    m_k = [[0.0] * n for _ in range(n)]
    c_k = 1.0
    for k in range(1, n + 1):
        m_k = [[_dot_row(a[i], m_k, j) + (c_k * 1.0 if i == j else 0.0) for j in range(n)]
               for i in range(n)]
        trace = 0.0
        for i in range(n):
            trace = trace + _dot_row(a[i], m_k, i)
        c_k = -trace / k
        coefficients.append(c_k)
    return coefficients


def _dot_row(row: list, m: list, j: int) -> float:
    """Σ_k row[k]·m[k][j] summed from 0.0 in order of k (an entry of ``casadi_mtimes``)."""
    total = 0.0
    for k, x in enumerate(row):
        total = total + x * m[k][j]
    return total


def poly_mul(p: list, q: list) -> list:
    """Product of two polynomials, highest power first."""
    out = [0] * (len(p) + len(q) - 1)
    for i, a in enumerate(p):
        for j, b in enumerate(q):
            out[i + j] = out[i + j] + a * b
    return out


def bilinear_to_continuous(coefficients: list) -> list:
    """Map a z-domain polynomial to w with z = (1 + w)/(1 − w), times (1 − w)^n.

    Roots inside the unit circle map to roots in the open left half plane, so the Hurwitz
    conditions of the result are the Schur stability conditions of the input.
    Highest power first on input and output.
    """
    n = len(coefficients) - 1
    result = [0] * (n + 1)
    for power, coefficient in enumerate(reversed(coefficients)):  # coefficient of z^power
        term = [coefficient]
        for _ in range(power):
            term = poly_mul(term, [1, 1])  # (w + 1)
        for _ in range(n - power):
            term = poly_mul(term, [-1, 1])  # (1 − w) = (−w + 1)
        for i, t in enumerate(term):
            result[i] = result[i] + t
    return result


def taylor_shift(poly: list, shift) -> list:
    """Coefficients of p(x + ``shift``), highest power first (Taylor shift by Horner's
    scheme, n(n+1)/2 multiply-adds)."""
    c = list(poly)
    n = len(c) - 1
    for i in range(n):
        for j in range(1, n - i + 1):
            c[j] = c[j] + shift * c[j - 1]
    return c


def poly_add(p: list, q: list) -> list:
    """Sum of two polynomials, highest power first."""
    n = max(len(p), len(q))
    p = [0] * (n - len(p)) + list(p)
    q = [0] * (n - len(q)) + list(q)
    return [a + b for a, b in zip(p, q)]


def poly_scale(p: list, factor) -> list:
    """``factor`` times the polynomial ``p``."""
    return [factor * c for c in p]


def poly_at_jw(p: list, omega):
    """Re and Im of p(jω), highest power first (Horner on the complex number jω)."""
    re, im = 0, 0
    for c in p:
        re, im = -omega * im + c, omega * re  # (re + j im)·jω + c
    return re, im


def companion_matrix(p: list):
    """Companion matrix whose eigenvalues are the roots of ``p`` (highest power first).

    Coefficients that are all Python numbers give a DM written straight into the layout
    of the expression's (:func:`_companion_layout`): the same entries and sparsity, in
    one conversion instead of a concatenation per row (a loop of numbers is built at
    every point of a robust search, a batch's reports and the contract tests' grids)."""
    n = len(p) - 1
    if all(isinstance(c, (int, float)) for c in p):
        pattern, slots = _companion_layout(n)
        lead = p[0]
        return ca.DM(pattern, [value if column is None else -p[column + 1] / lead
                               for column, value in slots])
    rows = [ca.horzcat(*[-c / p[0] for c in p[1:]])]
    if n > 1:
        rows.append(ca.horzcat(ca.DM.eye(n - 1), ca.DM.zeros(n - 1, 1)))
    return ca.vertcat(*rows)


@functools.lru_cache(maxsize=None)
def _companion_layout(n: int) -> tuple:
    """(sparsity, slots) of :func:`companion_matrix`'s matrix of degree ``n``: per stored
    entry (column-major), the column of the first row it holds −p[column + 1]/p[0] of, or
    None and its constant (the subdiagonal's 1, the last column's 0)."""
    rows = [ca.horzcat(*[ca.SX.sym(f"c{k}") for k in range(n)])]
    if n > 1:
        rows.append(ca.horzcat(ca.DM.eye(n - 1), ca.DM.zeros(n - 1, 1)))
    matrix = ca.vertcat(*rows)
    pattern = matrix.sparsity()
    row, column = pattern.row(), pattern.get_col()
    entries = matrix.nonzeros()
    return pattern, tuple((column[k], None) if row[k] == 0 else (None, float(entries[k]))
                          for k in range(len(row)))


def balanced_polynomial(p: list) -> list:
    """p(ω0·σ)/(a_n ω0^n) with ω0 = |a_0/a_n|^(1/n): monic, |constant term| 1, same stability.

    The substitution s = ω0·σ (ω0 > 0) moves every root radially, so the Hurwitz
    conditions of the result hold exactly when those of ``p`` do, while coefficients that
    spanned 1e-24 … 1e13 (a loop with corners from 1 to 10⁴ rad/s) become O(1) … O(10⁴).
    Highest power first.
    """
    n = len(p) - 1
    omega0 = ca.fabs(p[-1] / p[0]) ** (1.0 / n)
    return [c * omega0 ** (-i) / p[0] for i, c in enumerate(p)]


def hurwitz_conditions(coefficients: list) -> list:
    """Expressions that are all positive exactly when the polynomial is Hurwitz stable.

    Symbolic coefficients (SX/MX) get the conditions as one call of a Function of generic
    coefficients, built once per degree (:func:`_hurwitz_function`; expanded to SX they
    are inlined). Finite numbers get that Function evaluated
    (:func:`hurwitz_conditions_of_numbers`: the same operations, so the same bits, in one
    call where the operations written out are ≈ 80 CasADi calls on DM numbers: 0.43 →
    0.07 ms a polynomial of the robust searches' loops of numbers, degrees 3-9,
    benchmarks/search_numbers_speed.py); non-finite numbers by the operations written out
    (:func:`_hurwitz_conditions`), so that inf·0 stays NaN where the Function's SX has
    folded x·0 to 0.
    """
    kind = next((k for k in (ca.MX, ca.SX) if any(isinstance(c, k) for c in coefficients)),
                None)
    if kind is None:
        if all(math.isfinite(float(c)) for c in coefficients):
            return hurwitz_conditions_of_numbers(coefficients)
        return _hurwitz_conditions(coefficients)  # inf·0 stays NaN (SX folds x·0 to 0)
    values = _hurwitz_function(len(coefficients) - 1)(ca.vertcat(*[kind(c) for c in coefficients]))
    return [values[i] for i in range(values.numel())]


def hurwitz_conditions_of_numbers(coefficients: list) -> list:
    """:func:`hurwitz_conditions` of numbers (DM or floats) by the Function that symbolic
    coefficients get (:func:`_hurwitz_function`), evaluated: the same operations, so the
    same bits as evaluating the conditions of a loop of numbers built as expressions,
    without building them (a sampled loop's, with :func:`bilinear_to_continuous`, cost
    ≈ 3 ms of graph per tuned design)."""
    values = _hurwitz_function(len(coefficients) - 1)(ca.DM([float(c) for c in coefficients]))
    return ca.vertsplit(values) if values.numel() else []  # one DM a condition


@functools.lru_cache(maxsize=None)
def _hurwitz_function(degree: int):
    """:func:`_hurwitz_conditions` of ``degree + 1`` generic coefficients (highest power
    first), as an SX Function of them (callable on SX and MX alike)."""
    a = ca.SX.sym("a", degree + 1)
    return ca.Function(f"hurwitz{degree}", [a],
                       [ca.vertcat(*_hurwitz_conditions([a[i] for i in range(degree + 1)]))])


def _hurwitz_conditions(coefficients: list) -> list:
    """The conditions of :func:`hurwitz_conditions`, written out in CasADi operations.

    Liénard–Chipart form: every coefficient has the sign of the leading one (written as the
    product with the leading coefficient), and the leading principal minors Δ_2..Δ_{n-1}
    of the Hurwitz matrix of the polynomial times its leading coefficient are positive.
    Highest power first.

    The minors come from Routh's array: its first column holds r_k = Δ_k/Δ_{k−1}, so
    Δ_k = r_1⋯r_k, in O(n²) operations where a pivoted elimination per minor cost O(n⁴)
    (degree 12: 11 599 SX instructions and 0.2–0.4 s of CPU to build, against 300 and a
    few ms; measured 2026-11-27 on the user-defined PID + notch drive, load 6–15). The
    values are the minors' up to rounding: within 1e-13 relative of the determinants on
    seeded random polynomials up to degree 12 (tests/unit/test_linalg.py). A pivot r_k
    that is exactly 0 (Δ_k = 0: not stable) is replaced by the smallest normal number
    (:func:`routh_first_column`); the minors after it are then not finite or not
    positive, and the verdict stays "not stable".
    """
    n = len(coefficients) - 1
    lead = coefficients[0]
    conditions = [lead * c for c in coefficients[1:]]
    column = routh_first_column([lead * c for c in coefficients], n - 1)
    for k in range(1, len(column)):
        column[k] = column[k - 1] * column[k]  # Δ_{k+1} = r_1⋯r_{k+1}
        conditions.append(column[k])
    return conditions


def routh_first_column(coefficients: list, count: int) -> list:
    """The first ``count`` entries r_1, r_2, … of the first column of Routh's array of the
    polynomial (highest power first), after its leading coefficient: r_k = Δ_k/Δ_{k−1} of
    the Hurwitz minors (Δ_0 = 1). O(n²) operations. A pivot that is exactly 0 is replaced
    by the smallest normal number, so no row is NaN."""
    if count <= 0:
        return []
    rows = [list(coefficients[0::2]), list(coefficients[1::2])]
    column = [rows[1][0]]
    while len(column) < count:
        upper, lower = rows[-2], rows[-1]
        pivot = ca.if_else(lower[0] == 0, sys.float_info.min, lower[0])
        below = list(lower[1:]) + [0] * (len(upper) - len(lower))
        rows.append([(lower[0] * upper[j + 1] - upper[0] * below[j]) / pivot
                     for j in range(len(upper) - 1)] or [0])
        column.append(rows[-1][0])
    return column[:count]


def complex_solve(real_part, imag_part, rhs):
    """Solve (R + jI) x = b for real b; returns (Re x, Im x)."""
    n = real_part.shape[0]
    block = ca.vertcat(ca.horzcat(real_part, -imag_part), ca.horzcat(imag_part, real_part))
    solution = solve(block, ca.vertcat(rhs, ca.DM.zeros(n, 1)))
    return solution[:n], solution[n:]


def solve(matrix, rhs):
    """A⁻¹b; for MX with a symbolic QR that the NLP can expand to SX, else ``ca.solve``."""
    if isinstance(matrix, ca.MX) or isinstance(rhs, ca.MX):
        return ca.solve(ca.MX(matrix), ca.MX(rhs), "symbolicqr")
    return ca.solve(matrix, rhs)


def roots(p: list, iterations: int = 200) -> list[complex]:
    """The roots of ``p`` (numbers, highest power first) in pure Python, for time and
    frequency scales that a spec check needs without importing numpy (issue 15: ``feedtune
    validate`` under 0.3 s).

    Aberth–Ehrlich iteration (Bini, "Numerical computation of polynomial zeros by means of
    Aberth's method", Numer. Algorithms 13, 1996): every estimate moves by the Newton step
    corrected for the others, w = (p/p′)/(1 − (p/p′)·Σ_{j≠i} 1/(z_i − z_j)), from points on
    the circles of the Newton polygon's radii (:func:`_newton_polygon_starts`, Bini §3), so
    roots dozens of decades apart start near their own moduli. Roots at 0 (trailing zeros)
    are exact. Cubic convergence for simple roots, linear for multiple ones; stops when no
    estimate moves by more than 4 ulps of its magnitude. A scale, not an eigenvalue
    solver: numbers as numpy's ``roots`` to about 1e-12 relative for simple roots.
    """
    p = [complex(c) for c in p]
    while len(p) > 1 and p[0] == 0:
        p.pop(0)
    if len(p) == 1:
        return []
    monic = [c / p[0] for c in p]
    # trailing zeros, a coefficient that underflows to 0 once divided by the leading one
    # (5e-324/2) among them: roots at 0, each one less point for the Newton polygon
    zeros = 0
    while len(monic) > 1 and monic[-1] == 0:
        monic.pop()
        zeros += 1
    n = len(monic) - 1
    if n == 0:
        return [0j] * zeros
    derivative = [c * (n - i) for i, c in enumerate(monic[:-1])]
    z = _newton_polygon_starts(monic)

    def horner(q, x):
        value = 0j
        for c in q:
            value = value * x + c
        return value

    for _ in range(iterations):
        largest = 0.0
        for i in range(n):
            value, slope = horner(monic, z[i]), horner(derivative, z[i])
            if value == 0 or slope == 0:
                continue  # on a root, or on a critical point: the others move it
            ratio = value / slope
            repulsion = sum(1 / (z[i] - z[j]) for j in range(n) if j != i and z[i] != z[j])
            correction = 1 - ratio * repulsion
            step = ratio / correction if correction != 0 else ratio  # plain Newton there
            z[i] -= step
            largest = max(largest, abs(step) / max(abs(z[i]), 1e-300))
        if largest <= 4 * 2.0 ** -52:
            break
    return z + [0j] * zeros


def _newton_polygon_starts(monic: list[complex]) -> list[complex]:
    """Aberth's starting points for the monic ``monic`` (highest power first, degree n):
    the upper convex hull of the points (i, ln|a_i|), a_i the coefficient of x^i; an edge
    from i = k to k + m puts m points on the circle of radius (|a_k|/|a_(k+m)|)^(1/m), the
    modulus of m roots to within a factor of the degree (Bini 1996, §3, Newton polygon).
    A single edge (no coefficient above the line) is the circle of the mean radius
    |a_0|^(1/n)."""
    n = len(monic) - 1
    hull: list[tuple[int, float]] = []
    for i in range(n + 1):
        if monic[n - i] == 0:
            continue
        point = (i, math.log(abs(monic[n - i])))
        # drop the last point while it lies on or below the line from its predecessor
        # to this one (a non-negative cross product): the hull's upper side stays
        while len(hull) >= 2 and ((hull[-1][0] - hull[-2][0]) * (point[1] - hull[-2][1])
                                  - (hull[-1][1] - hull[-2][1]) * (point[0] - hull[-2][0])) >= 0:
            hull.pop()
        hull.append(point)
    starts = []
    for (k, log_k), (j, log_j) in zip(hull, hull[1:]):
        m = j - k
        radius = math.exp((log_k - log_j) / m)
        starts += [radius * cmath.exp(1j * (2 * math.pi * (t / m + k / n) + 0.4))
                   for t in range(m)]
    return starts


def pivoted_solve(matrix, rhs):
    """matrix⁻¹·rhs by Gaussian elimination with partial pivoting, in whole-matrix CasADi
    operations (the pivot row is chosen by comparisons and exchanged by a rank-one update, so
    derivatives are those of the chosen elimination): backward stable, where the QR of
    :func:`solve` loses digits as the square of the condition number.

    Works on SX, MX and DM alike. Measured (:mod:`feedtune.loops.sampled_lti`): on the README's
    sampled drive H(1) − 1 was −4.2e-7 (C_v 8.8e-7 off) and is
    now at rounding; on a contract loop with cond(I − Φ) = 5e5 (backward-Euler PI,
    T/T_i = 734) C_v was 5e-5 off the exact K_p, with symbolic and numeric evaluation
    disagreeing by 8e-6.
    """
    n = matrix.shape[0]
    work = ca.horzcat(matrix, rhs)
    lower = ca.DM([[1.0 if j <= i else 0.0 for j in range(n)] for i in range(n)])
    for k in range(n):
        rows = work[k:, :]
        size = ca.fabs(rows[:, k])
        flags = size >= ca.mmax(size)
        first = flags * (ca.mtimes(lower[:n - k, :n - k], flags) == 1)  # the first largest
        pivot_row = ca.mtimes(first.T, rows)
        # exchange row k and the pivot's row (nothing when the pivot is row k): O(n) per
        # entry, no permutation product
        rows = rows + ca.mtimes(first, rows[0, :] - pivot_row)
        rows = ca.vertcat(pivot_row, rows[1:, :])
        pivot = pivot_row[0, k]
        factors = rows[1:, k] / ca.if_else(pivot == 0, 1, pivot)
        work = ca.vertcat(work[:k, :], pivot_row, rows[1:, :] - ca.mtimes(factors, pivot_row))
    upper, y = work[:, :n], work[:, n:]
    solution = [None] * n
    for k in reversed(range(n)):
        row = y[k, :]
        if k + 1 < n:
            row = row - ca.mtimes(upper[k, k + 1:], ca.vertcat(*solution[k + 1:]))
        solution[k] = row / upper[k, k]
    return ca.vertcat(*solution)


def hessenberg(matrix):
    """(H, Q) with H = Qᵀ·A·Q upper Hessenberg and Q orthogonal, A = ``matrix`` (n×n SX/MX/DM).

    Householder reflections P_k = I − 2uuᵀ/uᵀu on columns k = 0 … n − 3 (Golub & Van Loan,
    *Matrix Computations*, 4th ed., Alg. 7.4.2), the reflection's sign that of the column's
    first entry (no cancellation); a column already zero below its subdiagonal leaves
    P_k = I. Written in CasADi operations, so a symbolic A gives H and Q as expressions:
    built once, they let every frequency of a resolvent C(zI − A)⁻¹b be solved in O(n²)
    (:func:`hessenberg_resolvent`) where a dense solve costs O(n³).
    """
    n = matrix.shape[0]
    a = matrix
    q = ca.DM.eye(n)
    for k in range(n - 2):
        x = a[k + 1:, k]
        alpha = -ca.if_else(x[0] >= 0, 1, -1) * ca.norm_2(x)
        u = ca.vertcat(ca.DM.zeros(k + 1, 1), x - ca.vertcat(alpha, ca.DM.zeros(n - k - 2, 1)))
        size = ca.sumsqr(u)
        reflect = ca.DM.eye(n) - 2 * ca.mtimes(u, u.T) / ca.if_else(size == 0, 1, size)
        a = ca.mtimes(ca.mtimes(reflect, a), reflect)
        q = ca.mtimes(q, reflect)
    return a, q


def _cmul(a, b):
    return a[0] * b[0] - a[1] * b[1], a[0] * b[1] + a[1] * b[0]


def _cdiv(a, b, select=None):
    size = b[0] ** 2 + b[1] ** 2
    size = (select or ca.if_else)(size == 0, 1, size)
    return (a[0] * b[0] + a[1] * b[1]) / size, (a[1] * b[0] - a[0] * b[1]) / size


def hessenberg_resolvent(h, rhs, row, shift_re, shift_im):
    """Re and Im of row·(zI − H)⁻¹·rhs for H upper Hessenberg (n×n), rhs n×1, row 1×n, at
    z = ``shift_re`` + j·``shift_im``: numbers or 1×m rows of them, one solve per column,
    every entry computed elementwise (so a whole row of frequencies is one expression).

    Gaussian elimination of the Hessenberg matrix: one subdiagonal entry per column, the
    pivot the larger of rows k and k + 1 in modulus (partial pivoting: backward stable as
    the dense solve), then back substitution; O(n²) complex operations per z.

    On numbers (H, rhs and row DM, z floats or DM rows: a loop of numbers' response at
    given ω) the same operations in the same order run on numpy floats, an array per
    entry instead of a DM call per entry and operation; the same IEEE results (a zero's
    sign aside: CasADi's select adds 0 to the value it picks). Returns DM rows then.
    """
    numbers = [h, rhs, row, shift_re, shift_im]
    if all(isinstance(v, (int, float, ca.DM)) for v in numbers):
        h, rhs, row, shift_re, shift_im = (np.array(v, dtype=float) for v in numbers)
        re, im = _hessenberg_solve(h, rhs.ravel(), row, shift_re.ravel() if shift_re.ndim
                                   else shift_re, shift_im.ravel() if shift_im.ndim
                                   else shift_im, np.where)
        return ca.DM(np.reshape(re, (1, -1))), ca.DM(np.reshape(im, (1, -1)))
    return _hessenberg_solve(h, rhs, row, shift_re, shift_im, ca.if_else)


def _hessenberg_solve(h, rhs, row, shift_re, shift_im, select):
    """:func:`hessenberg_resolvent`'s elimination; ``select(condition, a, b)`` is
    ``ca.if_else`` on CasADi types, ``numpy.where`` on numpy floats."""
    n = h.shape[0]
    # rows of (zI − H | rhs) as complex (re, im) pairs, columns k … n (n: the rhs)
    rows = []
    for i in range(n):
        entries = []
        for j in range(n):
            if j < i - 1:
                entries.append((0, 0))
            elif i == j:
                entries.append((shift_re - h[i, j], shift_im + 0 * shift_re))
            else:
                entries.append((-h[i, j], 0))
        entries.append((rhs[i], 0))
        rows.append(entries)
    for k in range(n - 1):
        top, bottom = rows[k], rows[k + 1]
        size_top = top[k][0] ** 2 + top[k][1] ** 2
        size_bottom = bottom[k][0] ** 2 + bottom[k][1] ** 2
        swap = size_bottom > size_top
        pivot_row = [tuple(select(swap, b, t) for t, b in zip(te, be))
                     for te, be in zip(top[k:], bottom[k:])]
        other = [tuple(select(swap, t, b) for t, b in zip(te, be))
                 for te, be in zip(top[k:], bottom[k:])]
        factor = _cdiv(other[0], pivot_row[0], select)
        products = [_cmul(factor, p) for p in pivot_row[1:]]
        reduced = [(0, 0)] + [(o[0] - m[0], o[1] - m[1]) for o, m in zip(other[1:], products)]
        rows[k] = rows[k][:k] + pivot_row
        rows[k + 1] = rows[k + 1][:k] + reduced
    solution = [None] * n
    for k in reversed(range(n)):
        re, im = rows[k][n]
        for j in range(k + 1, n):
            product = _cmul(rows[k][j], solution[j])
            re, im = re - product[0], im - product[1]
        solution[k] = _cdiv((re, im), rows[k][k], select)
    re = sum(row[0, j] * solution[j][0] for j in range(n))
    im = sum(row[0, j] * solution[j][1] for j in range(n))
    return re, im
