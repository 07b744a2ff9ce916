"""Exact time responses of a stable rational transfer function (numpy/scipy only).

What the time-domain metrics of loops given by polynomials need (Bhatia 1971, Ch. IV B):
the position error after a unit step (1 rad or 1 m) or a unit ramp (1 rad/s or 1 m/s) of
the reference, and the position after a unit load-torque step (1 N·m), with their
integrals ∫|e|, ∫e², ∫t|e|, settling time and extremes. No CasADi: these responses are
evaluated on a tuned design, never inside the NLP.

Method
------
A response y(t) to a unit step of G = num/den splits into its final value and a transient,
y(t) = y_ss + y_tr(t) with y_ss = G(0), and y_tr is the impulse response of the strictly
proper q/den, q = (num − y_ss·den)/s (exact: the constant term of the numerator is zero
by construction and is dropped, not divided). A ramp error is the step response of S/s
for a type-1 error transfer S = s·S₁, so y_ss = S₁(0) = 1/C_v and y_tr = e − e_ss.

The transient is realised in controllable companion form, balanced by a diagonal
similarity (LAPACK gebal), brought to complex Schur form, and block-diagonalised by
Sylvester equations into *clusters* of poles: poles closer to each other than
``CLUSTER_SPREAD`` times their decay rate share one block B_c = μ_c I + N_c. Each cluster
contributes exactly

    y_c(t) = Re( e^{μ_c t} Σ_j  c_c N_c^j x_c  t^j / j! ),

a finite sum for a repeated pole (N_c nilpotent) and a fast-converging series for close
poles (|N_c| t stays below a few units while the cluster is alive), so repeated and close
poles never produce the large cancelling residues of a partial-fraction expansion.
Distinct clusters are at least CLUSTER_SPREAD·σ apart, which bounds the condition of the
block-diagonalisation. The antiderivatives F = ∫y_tr (with F(∞) = 0) and H = ∫F are the
same sums with x_c replaced by B_c⁻¹x_c and B_c⁻²x_c, so

* ∫ y_tr over [a, b] = F(b) − F(a), ∫ t·y_tr = [tF − H] from a to b: exact;
* ∫|y_tr| and ∫t|y_tr| add those exact pieces between the zero crossings of y_tr, which
  are bracketed on a grid (fine enough for every living mode: ``GRID_PHASE`` rad per step
  of the fastest one, coarsened as fast modes die) and refined by Brent's method; an
  interval whose ends have one sign but whose derivative changes sign is searched for a
  pair of crossings at its extremum. A crossing located to δt changes ∫|y| by
  O(ẏ δt²) only, so the integrals are exact to rounding;
* ∫ y_tr² from the Lyapunov equation of the balanced realisation (exact, no grid).

Horizon: a cluster's *horizon* is where its envelope e^{Re μ t} Σ|c N^j x| t^j/j! has
fallen to ``DECAY`` (1e-12) of its largest value, i.e. ln(1e12)/σ for a simple pole of real
part −σ; the response's horizon is that of its slowest cluster (:attr:`Transient.horizon`,
the settling limit asked of every mode). Crossings and integrals are followed further, to
``CUTOFF`` (1e-18, :attr:`Transient.span`, 1.5 times as long), and the exact signed tail
−F(span) is added, so truncation stays below rounding: stopping at the 1e-12 horizon
instead would cost 1e-12 of a lightly damped loop's IAE and 3e-11 of its ITAE (the tail is
weighted by t ≈ 28/σ).

Accuracy, measured in tests/unit/test_timeresponse.py against closed forms (first and
second order with ζ from 0.02 to 0.95, a double and a triple pole, real poles 1e-9 to 0.5
apart written with expm1) and against adaptive quadrature between the crossings of an
independent expm evaluation (an eighth-order loop with coefficients over 18 decades, a
repeated complex pair): values to 1e-14 absolute for unit-size responses; IAE, ITAE, ISE,
overshoot and settling time to a relative 1e-12 or better (typically 1e-15 against closed
forms). Unstable (or marginally stable) responses are refused with
:class:`UnstableResponseError`; a loop so lightly damped that bracketing its crossings
would take more than ``MAX_GRID_POINTS`` grid points (ζ ≲ 1e-4) with
:class:`ResponseTooLongError`.

References
----------
S. Bhatia, "Feed drive design for numerically controlled machine tools", M.S. thesis,
University of Missouri–Rolla, 1971, Ch. IV B (IAE, ISE, ITAE; settling time, overshoot)
and Ch. IV F (step and ramp responses by partial fractions, Figs 35, 36).
C. Moler, C. Van Loan, "Nineteen dubious ways to compute the exponential of a matrix,
twenty-five years later", SIAM Review 45 (2003), §6 (block diagonalisation by Schur form
and Sylvester equations).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import cached_property, lru_cache

from feedtune.lazy import np
from feedtune.loops.protocols import Capability

DECAY = 1e-12  # a mode is followed until it has decayed to this fraction of its largest size
#: a mode's contribution is dropped once below this fraction of its largest size (far below
#: rounding, so dropping it never shows in the values, while its series stays bounded)
CUTOFF = 1e-18
CLUSTER_SPREAD = 0.1  # poles closer than this times their decay rate share a cluster
GRID_PHASE = 0.25  # grid step × (|μ| + spread) of the fastest living cluster [rad]
MAX_GRID_POINTS = 2_000_000
SERIES_TOLERANCE = 1e-18  # last series term relative to the largest, over the cluster's life
MAX_SERIES_TERMS = 400


class UnstableResponseError(ValueError):
    """The transfer function has a pole with non-negative real part: no response settles."""


class ResponseTooLongError(ValueError):
    """Bracketing the crossings would take more than MAX_GRID_POINTS grid points."""


def _trimmed(coefficients, name: str) -> np.ndarray:
    p = np.atleast_1d(np.asarray(coefficients, dtype=float))
    if p.ndim != 1 or not np.all(np.isfinite(p)):
        raise ValueError(f"{name} must be a finite 1-D array of coefficients")
    nonzero = np.flatnonzero(p)
    return p[nonzero[0]:] if nonzero.size else np.zeros(1)


@dataclass(frozen=True)
class _Cluster:
    """Poles sharing one Schur block: y_c(t) = Re(e^{μt} Σ_j coef[j] t^j/j!) up to ``end``."""

    mu: complex
    value: np.ndarray  # c N^j x
    derivative: np.ndarray  # c N^j B x
    integral: np.ndarray  # c N^j B⁻¹ x  (F, with F(∞) = 0)
    double_integral: np.ndarray  # c N^j B⁻² x  (H, with H(∞) = 0)
    end: float  # [s] after this the cluster is below DECAY of its largest size
    cutoff: float  # [s] after this it is below CUTOFF, and no longer evaluated
    spread: float  # max |pole − μ| [1/s] within the cluster


def _series(coefficients: np.ndarray, mu: complex, t: np.ndarray) -> np.ndarray:
    """Re(e^{μt} Σ_j coefficients[j] t^j/j!) by Horner's rule."""
    s = np.full(t.shape, coefficients[-1], dtype=complex)
    for j in range(len(coefficients) - 2, -1, -1):
        s = coefficients[j] + s * t / (j + 1)
    return (np.exp(mu * t) * s).real


def _clusters_of(poles: np.ndarray) -> list[list[int]]:
    """Single-linkage groups of poles closer than CLUSTER_SPREAD × the slower decay rate."""
    n = len(poles)
    parent = list(range(n))

    def root(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for i in range(n):
        for j in range(i + 1, n):
            rate = min(-poles[i].real, -poles[j].real)
            if abs(poles[i] - poles[j]) <= CLUSTER_SPREAD * rate:
                parent[root(i)] = root(j)
    groups: dict[int, list[int]] = {}
    for i in range(n):
        groups.setdefault(root(i), []).append(i)
    return list(groups.values())


def _block_diagonalise(a: np.ndarray, poles: np.ndarray, groups: list[list[int]]):
    """(W, blocks): a = W diag(blocks) W⁻¹, one complex triangular block per group."""
    from scipy.linalg import schur, solve_sylvester  # 0.2 s of every command: when used

    n = a.shape[0]
    w = np.eye(n, dtype=complex)
    m = a.astype(complex)
    blocks = []
    offset = 0
    remaining = [list(g) for g in groups]
    while remaining:
        group = remaining.pop(0)
        if not remaining:
            t, z = schur(m, output="complex")
            w[:, offset:] = w[:, offset:] @ z
            blocks.append(t)
            break
        members = poles[group]
        others = poles[[i for g in remaining for i in g]]

        def selected(x, members=members, others=others):
            return np.min(np.abs(members - x)) < np.min(np.abs(others - x))

        t, z, sdim = schur(m, output="complex", sort=selected)
        k = len(group)
        if sdim != k:
            raise ArithmeticError(f"Schur reordering selected {sdim} poles for a cluster of {k}")
        t11, t12, t22 = t[:k, :k], t[:k, k:], t[k:, k:]
        x = solve_sylvester(t11, -t22, -t12)  # t11 x − x t22 = −t12
        y = np.eye(m.shape[0], dtype=complex)
        y[:k, k:] = x
        w[:, offset:] = w[:, offset:] @ (z @ y)
        blocks.append(t11)
        m = t22
        offset += k
    return w, blocks


def _cluster(block: np.ndarray, row: np.ndarray, column: np.ndarray) -> _Cluster:
    """Series coefficients and life span of one cluster ``row · e^{block t} · column``."""
    k = block.shape[0]
    mu = complex(np.trace(block)) / k
    nil = block - mu * np.eye(k)
    sigma = -mu.real
    spread = float(np.max(np.abs(np.diag(nil)))) if k > 1 else 0.0
    # longest life to expect: ln(1/DECAY)/σ for a simple pole, more for polynomial factors
    life = (math.log(1 / CUTOFF) + 10 * (k - 1)) / max(sigma - spread, 0.5 * sigma)
    starts = {"value": column, "derivative": block @ column,
              "integral": np.linalg.solve(block, column)}
    starts["double_integral"] = np.linalg.solve(block, starts["integral"])
    coefficients = {}
    for name, v in starts.items():
        terms = []
        largest = -math.inf  # log of the largest term c_j life^j / j!
        for j in range(MAX_SERIES_TERMS):
            c = complex(row @ v)
            terms.append(c)
            size = (math.log(abs(c)) + j * math.log(life) - math.lgamma(j + 1)
                    if c != 0 else -math.inf)
            largest = max(largest, size)
            if j >= k and j > 2 * spread * life and (
                    size <= largest + math.log(SERIES_TOLERANCE) or not np.any(v)):
                break
            v = nil @ v
        else:
            raise ArithmeticError("a cluster's series did not converge; poles too spread")
        coefficients[name] = np.array(terms)
    end = _cluster_end(coefficients["value"], mu, life, DECAY)
    cutoff = _cluster_end(coefficients["value"], mu, life, CUTOFF)
    return _Cluster(mu, coefficients["value"], coefficients["derivative"],
                    coefficients["integral"], coefficients["double_integral"], end, cutoff,
                    spread)


def _cluster_end(value: np.ndarray, mu: complex, life: float, fraction: float) -> float:
    """First time [s] after the envelope's peak at which it is ``fraction`` of that peak.

    Envelope: e^{Re μ t} Σ_j |value_j| t^j / j!, a bound on the cluster's contribution.
    """
    magnitudes = np.abs(value)
    if not np.any(magnitudes):
        return 0.0
    sigma = -mu.real
    used = [(j, m) for j, m in enumerate(magnitudes) if m > 0]

    if len(used) == 1 and used[0][0] == 0:  # a simple pole: |c| e^{−σt}
        return math.log(1 / fraction) / sigma

    def log_envelope(t):
        t = np.asarray(t, dtype=float)
        with np.errstate(divide="ignore"):
            log_t = np.log(t)
        logs = [np.full(t.shape, math.log(m)) if j == 0 else
                math.log(m) + j * log_t - math.lgamma(j + 1) for j, m in used]
        return np.logaddexp.reduce(np.array(logs), axis=0) - sigma * t

    ts = np.linspace(0.0, life, 2001)
    logs = log_envelope(ts)
    peak = int(np.argmax(logs))
    target = logs[peak] + math.log(fraction)
    below = np.flatnonzero(logs[peak:] <= target)
    if below.size:
        lo, hi = ts[peak + below[0] - 1], ts[peak + below[0]]
    else:  # polynomial factors of a large cluster: double until below
        lo, hi = life, 2 * life
        while log_envelope(hi) > target:
            lo, hi = hi, 2 * hi
    from scipy.optimize import brentq  # 0.11 s of every command: imported when used

    return float(brentq(lambda t: float(log_envelope(t)) - target, lo, hi,
                        xtol=1e-300, rtol=1e-12))


class Transient:
    """y_tr(t), the impulse response of a stable strictly proper q/den, with its integrals.

    Build with :func:`step_response`; times [s], values in the unit of the response.
    """

    def __init__(self, numerator: np.ndarray, denominator: np.ndarray):
        from scipy.linalg import matrix_balance  # 0.2 s of every command: when used

        n = len(denominator) - 1
        self.order = n
        self.clusters: list[_Cluster] = []
        self._realisation = None
        self.poles = np.zeros(0, dtype=complex)
        if n == 0:
            return
        a_coeffs = denominator[1:] / denominator[0]
        b = np.zeros(n)
        b[n - len(numerator):] = numerator / denominator[0]
        companion = np.zeros((n, n))
        companion[0, :] = -a_coeffs
        companion[np.arange(1, n), np.arange(n - 1)] = 1.0
        a, scaling = matrix_balance(companion, permute=False)
        scale = np.diag(scaling)
        column = np.zeros(n)
        column[0] = 1.0 / scale[0]  # T⁻¹B with B = e₁
        row = b * scale  # C T
        poles = np.linalg.eigvals(a)
        if np.any(poles.real >= 0):
            worst = poles[np.argmax(poles.real)]
            raise UnstableResponseError(
                f"the response does not settle: pole {worst:.6g} has a non-negative real part")
        self.poles = poles
        if not np.any(b):
            return  # no transient
        self._realisation = (a, column, row)
        groups = _clusters_of(poles)
        w, blocks = _block_diagonalise(a, poles, groups)
        x = np.linalg.solve(w, column.astype(complex))
        c = row.astype(complex) @ w
        offset = 0
        clusters = []
        for block in blocks:
            k = block.shape[0]
            clusters.append(_cluster(block, c[offset:offset + k], x[offset:offset + k]))
            offset += k
        # a conjugate pair ends together, else its sum turns complex past the earlier end
        for i, cl in enumerate(clusters):
            mates = [o for o in clusters if abs(o.mu - cl.mu.conjugate()) <= 1e-8 * abs(cl.mu)]
            clusters[i] = replace(cl, end=max([cl.end, *(m.end for m in mates)]),
                                  cutoff=max([cl.cutoff, *(m.cutoff for m in mates)]))
        self.clusters = clusters

    # -- evaluation ---------------------------------------------------------------------

    @property
    def horizon(self) -> float:
        """t_end [s]: every cluster has decayed to DECAY of its largest size."""
        return max((cl.end for cl in self.clusters), default=0.0)

    @property
    def span(self) -> float:
        """[s] every cluster has decayed to CUTOFF: crossings and integrals are followed this
        far, so truncating them costs less than rounding does."""
        return max((cl.cutoff for cl in self.clusters), default=0.0)

    def _sum(self, kind: str, t) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        out = np.zeros(t.shape)
        for cl in self.clusters:
            alive = t <= cl.cutoff
            if np.any(alive):
                out[alive] += _series(getattr(cl, kind), cl.mu, t[alive])
        return out

    def __call__(self, t):
        """y_tr(t)."""
        return self._sum("value", t)

    def derivative(self, t):
        """ẏ_tr(t)."""
        return self._sum("derivative", t)

    def antiderivative(self, t):
        """F(t) = −∫_t^∞ y_tr: the antiderivative that vanishes at infinity."""
        return self._sum("integral", t)

    def moment_antiderivative(self, t):
        """G(t) = t F(t) − H(t), antiderivative of t·y_tr vanishing at infinity."""
        t = np.asarray(t, dtype=float)
        return t * self._sum("integral", t) - self._sum("double_integral", t)

    def _scalar(self, kind: str):
        """``t ↦ float(self._sum(kind, [t]))`` to the last bit, for Brent's method.

        Every cluster's :func:`_series` at once: the coefficients as rows of one matrix,
        padded with zeros at the high powers (Horner's steps through a zero give exactly the
        first real coefficient, so every cluster's steps are its own), the living clusters'
        terms then added in the array path's order. Measured on
        ``examples/user-defined-pid-notch.json``'s reports (114 root searches, ≈ 900 calls):
        ≈ 170 → 25 µs a call, one series a cluster on a one-element array before."""
        clusters = self.clusters
        if not clusters:
            return lambda t: 0.0
        rows = [np.asarray(getattr(cl, kind)) for cl in clusters]
        width = max(len(r) for r in rows)
        matrix = np.zeros((len(rows), width), dtype=complex)
        for i, r in enumerate(rows):
            matrix[i, :len(r)] = r
        columns = [matrix[:, j].copy() for j in range(width)]
        mu = np.array([cl.mu for cl in clusters], dtype=complex)
        cutoff = np.array([cl.cutoff for cl in clusters], dtype=float)

        def value(t) -> float:
            t = float(t)
            alive = t <= cutoff
            if not alive.any():
                return 0.0
            s = columns[-1]
            for j in range(width - 2, -1, -1):
                s = columns[j] + s * t / (j + 1)
            terms = (np.exp(mu * t) * s).real[alive]
            total = 0.0
            for term in terms.tolist():
                total += term
            return total

        return value

    # -- grid, crossings, extrema ---------------------------------------------------------

    @cached_property
    def grid(self) -> np.ndarray:
        """Times [s] from 0 to :attr:`span`, a step of GRID_PHASE/(|μ| + spread) of the
        fastest cluster still evaluated in each stretch."""
        if self.span == 0:
            return np.zeros(1)
        ends = sorted({cl.cutoff for cl in self.clusters if cl.cutoff > 0})
        pieces = []
        start = 0.0
        total = 0
        for end in ends:
            if end <= start:
                continue
            alive = [cl for cl in self.clusters if cl.cutoff >= end]
            rate = max(abs(cl.mu) + cl.spread for cl in alive)
            count = max(2, math.ceil((end - start) * rate / GRID_PHASE))
            total += count
            if total > MAX_GRID_POINTS:
                raise ResponseTooLongError(
                    f"the response lives {self.horizon:.3g} s with modes up to {rate:.3g} "
                    f"rad/s: more than {MAX_GRID_POINTS} grid points (a lightly damped loop)")
            pieces.append(np.linspace(start, end, count + 1)[:-1])
            start = end
        pieces.append(np.array([start]))
        return np.concatenate(pieces)

    @cached_property
    def _grid_values(self) -> tuple[np.ndarray, np.ndarray]:
        return self(self.grid), self.derivative(self.grid)

    @cached_property
    def _scalars(self) -> dict:
        """kind → :meth:`_scalar` of it, made once per transient (its matrix of coefficients)."""
        return {}

    def _root(self, kind: str, lo: float, hi: float, offset: float = 0.0) -> float:
        """The zero of (value or derivative) − offset bracketed by [lo, hi], by Brent's method.

        The tolerance is relative (4ε of the root), so a root at t = 0 to rounding (ẏ_tr(0)
        = 4.5e-15 where it is 0 in exact arithmetic: a turn between the first two grid
        points) is bracketed down to 4ε of 1e-17 s, which took Brent 108 iterations on
        Bhatia's loop with σ_min ≥ 12 1/s (tests/reference/test_new_metrics.py); after its
        100 the bracket is already far below any time the response resolves, and its point
        is the root (``disp=False``; it raised, and the tuning ended in an error). A root
        that converges is returned as before, to the bit."""
        f = self._scalars.get(kind)
        if f is None:
            f = self._scalars[kind] = self._scalar(kind)
        from scipy.optimize import brentq  # imported when used (see above)

        return brentq(lambda t: f(t) - offset, lo, hi, xtol=1e-300, rtol=4 * np.finfo(float).eps,
                      disp=False)

    @cached_property
    def _extrema(self) -> tuple[np.ndarray, np.ndarray]:
        """Times and values of the interior local extrema (sign changes of ẏ_tr)."""
        t = self.grid
        _, d = self._grid_values
        turns = np.flatnonzero(d[:-1] * d[1:] < 0)
        times = np.array([self._root("derivative", t[i], t[i + 1]) for i in turns])
        return times, self(times)

    @cached_property
    def crossings(self) -> np.ndarray:
        """Times [s] where y_tr changes sign (or touches zero on a grid point), sorted."""
        t = self.grid
        v, d = self._grid_values
        roots = [self._root("value", t[i], t[i + 1]) for i in np.flatnonzero(v[:-1] * v[1:] < 0)]
        roots += list(t[1:-1][v[1:-1] == 0])
        # same sign at both ends, but turning back towards zero inside: a pair of crossings?
        turning = np.flatnonzero((v[:-1] * v[1:] > 0) & (d[:-1] * d[1:] < 0)
                                 & ((d[:-1] < 0) == (v[:-1] > 0)))
        for i in turning:
            tm = self._root("derivative", t[i], t[i + 1])
            if float(self(np.array([tm]))[0]) * v[i] < 0:
                roots += [self._root("value", t[i], tm), self._root("value", tm, t[i + 1])]
        return np.sort(np.array(roots, dtype=float))

    # -- integrals --------------------------------------------------------------------------

    def integral(self) -> float:
        """∫_0^∞ y_tr dt = −F(0) (signed)."""
        return -float(self.antiderivative(0.0))

    def _absolute(self, antiderivative) -> float:
        points = np.concatenate([[0.0], self.crossings, [self.span]])
        values = antiderivative(points)
        inside = float(np.sum(np.abs(np.diff(values))))
        return inside + abs(float(values[-1]))  # tail: −F(span), below CUTOFF

    @cached_property
    def iae(self) -> float:
        """∫_0^∞ |y_tr| dt, exact between crossings."""
        return self._absolute(self.antiderivative) if self.clusters else 0.0

    @cached_property
    def itae(self) -> float:
        """∫_0^∞ t |y_tr| dt, exact between crossings."""
        return self._absolute(self.moment_antiderivative) if self.clusters else 0.0

    @cached_property
    def ise(self) -> float:
        """∫_0^∞ y_tr² dt = C W Cᵀ, A W + W Aᵀ + B Bᵀ = 0 (controllability Gramian)."""
        from scipy.linalg import solve_continuous_lyapunov  # 0.2 s of every command: when used

        if self._realisation is None:
            return 0.0
        a, column, row = self._realisation
        gramian = solve_continuous_lyapunov(a, -np.outer(column, column))
        return float(max(row @ gramian @ row, 0.0))

    # -- extremes and settling ------------------------------------------------------------

    def extremes(self) -> tuple[float, float]:
        """(min, max) of y_tr over [0, ∞), the final value 0 included."""
        v, _ = self._grid_values
        _, values = self._extrema
        candidates = np.concatenate([v, values, [0.0]])
        return float(np.min(candidates)), float(np.max(candidates))

    def last_exit(self, bound: float) -> float:
        """Last time [s] at which |y_tr| = ``bound`` (> 0): |y_tr| ≤ bound ever after.

        0 when |y_tr| never exceeds ``bound``.

        Raises
        ------
        ValueError
            When ``bound`` is so small that |y_tr| still exceeds it at the horizon.
        """
        if not bound > 0:
            raise ValueError("the settling bound must be positive")
        if not self.clusters:
            return 0.0
        t = self.grid
        v, _ = self._grid_values
        outside = np.flatnonzero(np.abs(v) > bound)
        if outside.size and outside[-1] == len(t) - 1:
            raise ValueError(f"a band of {bound:.3g} is below what the response resolves at "
                             f"its horizon ({abs(v[-1]):.3g})")
        last = int(outside[-1]) if outside.size else -1
        times, values = self._extrema
        late = np.flatnonzero((times > (t[last] if last >= 0 else -1.0))
                              & (np.abs(values) > bound))
        if late.size:  # an extremum between grid points is the last excursion
            tm, sign = times[late[-1]], math.copysign(1.0, values[late[-1]])
            after = t[np.searchsorted(t, tm)]
            return self._root("value", tm, after, sign * bound)
        if last < 0:
            return 0.0
        return self._root("value", t[last], t[last + 1], math.copysign(bound, v[last]))


@dataclass(frozen=True)
class Response:
    """y(t) = steady + transient(t) after a unit step of a stable G.

    Attributes
    ----------
    steady : float
        Final value y_ss = G(0) (for a ramp error: the steady following error e_ss).
    transient : Transient
        y(t) − y_ss, with its exact integrals.
    """

    steady: float
    transient: Transient

    def __call__(self, t):
        return self.steady + self.transient(t)

    @property
    def horizon(self) -> float:
        return self.transient.horizon

    def extremes(self) -> tuple[float, float]:
        """(min, max) of y over [0, ∞)."""
        lo, hi = self.transient.extremes()
        return self.steady + lo, self.steady + hi


@lru_cache(maxsize=64)
def _cached_step_response(num: tuple, den: tuple) -> Response:
    num_a, den_a = np.array(num), np.array(den)
    steady = num_a[-1] / den_a[-1]
    padded = np.zeros(len(den_a))
    padded[len(den_a) - len(num_a):] = num_a
    q = (padded - steady * den_a)[:-1]  # constant term is zero: divide by s exactly
    return Response(float(steady), Transient(_trimmed(q, "numerator") if q.size else np.zeros(1),
                                             den_a))


def step_response(numerator, denominator) -> Response:
    """Response of G = numerator/denominator (highest power first) to a unit step.

    Raises
    ------
    UnstableResponseError
        When G has a pole with Re ≥ 0 (no final value).
    ValueError
        When G is improper or the coefficients are not finite.
    """
    num = _trimmed(numerator, "numerator")
    den = _trimmed(denominator, "denominator")
    if not np.any(den):
        raise ValueError("the denominator is zero")
    if len(num) > len(den):
        raise ValueError("the transfer function is improper (numerator degree above denominator)")
    if den[-1] == 0:
        raise UnstableResponseError("the response does not settle: pole at s = 0")
    return _cached_step_response(tuple(num.tolist()), tuple(den.tolist()))


def reference_error(error_numerator, denominator, input: str = "step") -> Response:
    """Position error e = r − y after a unit step (1 rad) or unit ramp (1 rad/s) of r.

    ``error_numerator``/``denominator`` is the error transfer S = 1 − T. For a ramp, S must
    have a zero at s = 0 (a loop of type 1 or higher); e(t) − e_ss is the transient, with
    e_ss = 1/C_v the steady following error of a type-1 loop.
    """
    num = _trimmed(error_numerator, "numerator")
    if input == "step":
        return step_response(num, denominator)
    if input == "ramp":
        if num[-1] != 0:
            raise ValueError("the ramp error grows without bound: the loop is of type 0")
        return step_response(num[:-1], denominator)
    raise ValueError(f"unknown input {input!r}; use 'step' or 'ramp'")


def load_response(load_numerator, denominator) -> Response:
    """Position after a unit (1 N·m) load-torque step; steady = the static load error."""
    return step_response(load_numerator, denominator)


# -- the sampled-data loop: exact between samples -------------------------------------------

class SampledStepError:
    """Position error e(t) = 1 − x(t) of a sampled loop after a unit position step, exact
    at every t: samples from the loop's recurrence, and in closed form in between.

    Over sample n the command u = k_x·ξ(n) + k_r is held (zero-order hold) and the drive
    1/(s(1 + sτ)) moves from position x, velocity v as
    e(σ) = α + β·s + γ·e^{−s}, s = σ/τ, with α = 1 − x − (v − u)τ, β = −uτ, γ = (v − u)τ
    (Koren eqs 12–14); the ideal drive 1/s (τ None) gives e(σ) = 1 − x − uσ. Each sample
    therefore has at most one interior extremum, at e^{−s} = β/γ, so extremes and the last
    exit from a band are exact (Brent's method only on a monotone piece).

    Parameters
    ----------
    phi, gamma, kx, kr, period, tau
        Closed-loop Φ, Γ of ξ(n + 1) = Φξ(n) + Γ·r, the held command's k_x, k_r, the
        period T [s] and τ [s] (None: ideal drive), from
        :meth:`feedtune.loops.loop.SampledLoop.numeric_hold`; the state starts at rest with the
        drive's position and velocity first.
    samples : int
        Samples followed (until the free response has decayed far below any band).
    """

    def __init__(self, phi, gamma, kx, kr, period: float, tau: float | None, samples: int):
        if np.max(np.abs(np.linalg.eigvals(phi)), initial=0.0) >= 1:
            raise UnstableResponseError("the sampled loop is not stable: no response settles")
        states = np.empty((samples, phi.shape[0]))
        state = np.zeros(phi.shape[0])
        step = np.asarray(phi).dot  # phi @ state by the same BLAS call (gemv, the same
        for n in range(samples):  # layout), so the same bits; ≈ 1/3 less a sample than @
            states[n] = state  # and a new array for the sum
            state = step(state)
            state += gamma
        u = states @ kx + kr
        self.period, self.tau, self.samples = period, tau, samples
        x = states[:, 0]
        if tau is None:  # e = α + β·σ [σ in s]
            self.alpha, self.beta, self.gamma = 1 - x, -u, np.zeros(samples)
            self.end = period
        else:
            v = states[:, 1]
            self.alpha, self.beta, self.gamma = 1 - x - (v - u) * tau, -u * tau, (v - u) * tau
            self.end = period / tau

    def _at(self, n, s):
        """e in sample n at local coordinate s (σ/τ, or σ [s] for the ideal drive)."""
        decay = np.exp(-s) if self.tau is not None else 0.0
        return self.alpha[n] + self.beta[n] * s + self.gamma[n] * decay

    def _turn(self):
        """Local coordinate of each sample's interior extremum, NaN where there is none."""
        with np.errstate(divide="ignore", invalid="ignore"):
            s = np.log(self.gamma / self.beta)
        inside = (self.tau is not None) & np.isfinite(s) & (s > 0) & (s < self.end)
        return np.where(inside, s, np.nan)

    def _time(self, n, s) -> float:
        return n * self.period + s * (self.tau if self.tau is not None else 1.0)

    def lowest(self) -> float:
        """min over t ≥ 0 of e(t) [m], the final value 0 included."""
        n = np.arange(self.samples)
        turn = self._turn()
        candidates = [self.alpha + self.gamma, np.where(np.isnan(turn), np.inf,
                                                         self._at(n, np.nan_to_num(turn)))]
        return float(min(0.0, *(np.min(c) for c in candidates)))

    def last_exit(self, bound: float) -> float:
        """Last time [s] at which |e| = ``bound`` (> 0): |e| ≤ bound ever after; 0 when
        |e| never exceeds it.

        Raises
        ------
        ValueError
            When |e| still exceeds ``bound`` in the last sample followed.
        """
        if not bound > 0:
            raise ValueError("the settling bound must be positive")
        n = np.arange(self.samples)
        turn = self._turn()
        start, stop = self._at(n, 0.0), self._at(n, self.end)
        inner = np.where(np.isnan(turn), 0.0, self._at(n, np.nan_to_num(turn)))
        outside = np.flatnonzero((np.abs(start) > bound) | (np.abs(stop) > bound)
                                 | (np.abs(inner) > bound))
        if outside.size == 0:
            return 0.0
        k = int(outside[-1])
        if k == self.samples - 1:
            raise ValueError(f"a band of {bound:.3g} is below what the response resolves at "
                             f"its horizon ({abs(stop[k]):.3g})")
        # monotone pieces of sample k, the last first: [turn, end] then [0, turn]
        edges = [0.0, self.end] if np.isnan(turn[k]) else [0.0, float(turn[k]), self.end]
        from scipy.optimize import brentq  # imported when used (see above)

        for a, b in reversed(list(zip(edges[:-1], edges[1:]))):
            ea, eb = self._at(k, a), self._at(k, b)
            roots = [brentq(lambda s: self._at(k, s) - level, a, b, xtol=1e-300,
                            rtol=4 * np.finfo(float).eps)
                     for level in (bound, -bound) if (ea - level) * (eb - level) < 0]
            if roots:
                return self._time(k, max(roots))
            if max(abs(ea), abs(eb)) > bound:  # touches the band at a piece's end
                return self._time(k, b if abs(eb) >= bound else a)
        raise AssertionError("unreachable: sample k leaves the band")


def has_sampled_step(loop) -> bool:
    """The loop is a sampled-data loop whose step response :class:`SampledStepError` gives."""
    return loop.offers(Capability.HELD_COMMAND)


@lru_cache(maxsize=4)
def sampled_step_error(loop) -> SampledStepError | None:
    """The exact step error of a sampled loop of numbers; None when it is unstable.

    Kept for the last few loops (a loop hashes by identity, and is held here so its
    identity stays its own): overshoot and settling time read the same response, which
    is not changed after it is built.

    Raises
    ------
    TypeError
        For a loop of symbols (these metrics are reported on the tuned design only).
    HorizonError
        (from the loop) When the response needs more samples than the loop allows.
    """
    hold = loop.numeric_hold()
    try:
        return SampledStepError(*hold, samples=loop.horizon_samples + 1)
    except UnstableResponseError:
        return None
