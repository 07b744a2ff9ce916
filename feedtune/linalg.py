"""Small linear-algebra helpers written in CasADi operations.

Every function here works on CasADi symbols (SX/MX) and on numbers (DM) alike, so the
same expression serves the NLP and the evaluation of a tuned design.
"""

from __future__ import annotations

import casadi as ca


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
    coefficients = [ca.DM(1.0)]
    m_k = ca.DM.zeros(n, n)
    c_k = ca.DM(1.0)
    for k in range(1, n + 1):
        m_k = ca.mtimes(matrix, m_k) + c_k * ca.DM.eye(n)
        c_k = -ca.trace(ca.mtimes(matrix, m_k)) / k
        coefficients.append(c_k)
    return coefficients


def _poly_mul(p: list, q: list) -> list:
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
            term = _poly_mul(term, [1, 1])  # (w + 1)
        for _ in range(n - power):
            term = _poly_mul(term, [-1, 1])  # (1 − w) = (−w + 1)
        for i, t in enumerate(term):
            result[i] = result[i] + t
    return result


def hurwitz_conditions(coefficients: list) -> list:
    """Expressions that are all positive exactly when the polynomial is Hurwitz stable.

    Liénard–Chipart form: every coefficient has the sign of the leading one (written as the
    product with the leading coefficient), and the leading principal minors Δ_2..Δ_{n-1}
    of the Hurwitz matrix of the polynomial normalised to a positive leading coefficient
    are positive. Highest power first.
    """
    n = len(coefficients) - 1
    lead = coefficients[0]
    conditions = [lead * c for c in coefficients[1:]]
    # ascending coefficients a[0..n]; Hurwitz matrix entry (i, j) is a_{n-(2j-i)}
    a = list(reversed(coefficients))
    for k in range(2, n):
        rows = []
        for i in range(1, k + 1):
            row = []
            for j in range(1, k + 1):
                index = n - (2 * j - i)
                row.append(a[index] * lead if 0 <= index <= n else 0)
            rows.append(row)
        minor = ca.vertcat(*[ca.horzcat(*row) for row in rows])
        conditions.append(ca.det(minor))
    return conditions


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
