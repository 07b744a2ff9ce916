"""Exact simulation of every axis' closed loop over a whole program, vectorised.

Each axis is the closed loop feedtune already builds for its plant (reference → position,
:func:`feedtune.loops.export.closed_loop_state_space`), made discrete at the machine's
sampling period T and exact at the sampling instants:

* a **sampled** loop (Koren's sampled-data servo, a user's sampled drive) is discrete
  already; its period must be T. The reference is read at the sampling instants.
* a **continuous** loop (Koren's reference-pulse loop, Bhatia's cascades, a user's
  continuous drive) sees the interpolator's reference as a straight line between sampling
  instants: the pulses of one period are spread evenly over it (Koren's reference-pulse
  interpolator), a first-order hold. Its exact discretisation is the exponential of
  ``[[A T, B T, 0], [0, 0, 1], [0, 0, 0]]`` (Franklin, Powell & Workman, *Digital Control
  of Dynamic Systems*, 3rd ed., §6.3.2): x(k+1) = Φ x(k) + (Γ₁ − Γ₂) r(k) + Γ₂ r(k+1),
  exact for any reference linear between samples.

A cross-coupled controller's correction c(k) is computed at the sampling instant and held
(zero-order hold) over the period; it is added to each axis' position reference, which
for a loop that acts on its position error r − y is the correction added to the error
(Koren 1980, Fig 2). Its input column is Γ₁ (continuous) or B (sampled).

Independent axes are simulated by :func:`simulate_lti`: the samples are cut into blocks
of L; the zero-state response inside every block is one matrix product with the
lower-triangular Toeplitz matrix of the Markov parameters C Φ^{j−1} Γ, the free response
one product with the observability rows C Φ^i, and only the L-times fewer block-start
states are a recursion (numpy over blocks). This is the state recursion reorganised, not
an approximation: it agrees with the per-sample recursion to rounding
(``tests/unit/machine/test_simulate.py``).

References
----------
Y. Koren, "Cross-coupled biaxial computer control for manufacturing systems", ASME J.
Dyn. Sys., Meas., Control 102(4), 1980, pp. 265–272.
S. Bhatia, *Feed drive design for NC machine tools*, 1971, ch. 5 (Fig 38: x and y servos
simulated together over a profile by their state equations).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm

#: relative mismatch allowed between a sampled loop's own period and the machine's [1]
PERIOD_RTOL = 1e-9
#: the run-out after the program ends lasts until the slowest mode has decayed by this [1]
RUN_OUT_DECAY = 1e-9
#: samples per block of :func:`simulate_lti` (cost ∝ N·L for the products, N/L recursion)
BLOCK = 64


class UnstableAxis(ValueError):
    """An axis whose closed loop is unstable at the sampling period (spectral radius ≥ 1)."""


@dataclass(frozen=True)
class AxisModel:
    """One axis' closed loop, discrete at ``period`` T [s].

    x(k+1) = Φ x(k) + Γ [r(k), r(k+1), c(k)]ᵀ, y(k) = C x(k) + D r(k): r the axis'
    position reference [m], c a correction held over the period [m], y the position [m].

    Attributes
    ----------
    phi : ndarray (n, n)
    gamma : ndarray (n, 3)
        Columns for r(k), r(k+1) (zero for a sampled loop) and c(k).
    c : ndarray (n,)
    d : float
        Feedthrough of r(k) [1] (a proper continuous loop).
    period : float
        T [s].
    continuous : bool
        The loop itself is continuous (first-order hold of the reference).
    """

    phi: np.ndarray
    gamma: np.ndarray
    c: np.ndarray
    d: float
    period: float
    continuous: bool

    @property
    def spectral_radius(self) -> float:
        """max |λ(Φ)| [1]; below 1 for a stable loop."""
        return float(np.max(np.abs(np.linalg.eigvals(self.phi)))) if len(self.phi) else 0.0


def discretise(a, b, c, d, dt: float, period: float) -> AxisModel:
    """The :class:`AxisModel` of a closed loop (A, B, C, D) at the sampling ``period`` [s].

    Parameters
    ----------
    a, b, c, d : array_like
        The closed loop, reference → position; continuous when ``dt`` is 0.
    dt : float
        The loop's own sampling period [s], 0 for a continuous loop.
    period : float
        The machine's sampling period T [s].

    Raises
    ------
    ValueError
        A sampled loop whose period is not ``period``.
    """
    a = np.atleast_2d(np.asarray(a, dtype=float))
    b = np.asarray(b, dtype=float).reshape(-1)
    c = np.asarray(c, dtype=float).reshape(-1)
    d = float(np.asarray(d, dtype=float).reshape(-1)[0])
    n = len(a)
    if dt:
        if abs(dt - period) > PERIOD_RTOL * period:
            raise ValueError(f"the loop samples every {dt:.9g} s, the machine every "
                             f"{period:.9g} s")
        return AxisModel(a, np.column_stack([b, np.zeros(n), b]), c, d, period, False)
    m = np.zeros((n + 2, n + 2))
    m[:n, :n], m[:n, n], m[n, n + 1] = a * period, b * period, 1.0
    e = expm(m)
    g1, g2 = e[:n, n], e[:n, n + 1]
    return AxisModel(e[:n, :n], np.column_stack([g1 - g2, g2, g1]), c, d, period, True)


def simulate_lti(phi, gamma, c, d, u, x0=None, block: int = BLOCK) -> np.ndarray:
    """y(k) = C x(k) + d·u(k) of x(k+1) = Φ x(k) + Γ u(k), for all k, without a Python
    loop per sample.

    Parameters
    ----------
    phi : ndarray (n, n)
    gamma : ndarray (n, m)
    c : ndarray (n,)
    d : ndarray (m,)
        Feedthrough of each input.
    u : ndarray (N, m)
        Inputs at the samples.
    x0 : ndarray (n,), optional
        Initial state (zero).
    block : int
        Samples per block L.

    Returns
    -------
    ndarray (N,)
    """
    u = np.asarray(u, dtype=float)
    total, m = u.shape
    n = len(phi)
    if total == 0:
        return np.zeros(0)
    size = min(block, total)
    count = -(-total // size)
    padded = np.zeros((count * size, m))
    padded[:total] = u
    blocks = padded.reshape(count, size, m)
    powers = np.empty((size + 1, n, n))
    powers[0] = np.eye(n)
    for j in range(size):
        powers[j + 1] = phi @ powers[j]
    rows = np.einsum("j,ijk->ik", c, powers[:size])  # C Φ^i, (L, n)
    markov = rows[:size - 1] @ gamma  # C Φ^{j−1} Γ for j = 1 … L−1, (L−1, m)
    lag = np.arange(size)[:, None] - np.arange(size)[None, :]  # i − j
    toeplitz = np.zeros((size, size, m))
    below = lag > 0
    toeplitz[below] = markov[lag[below] - 1]
    toeplitz[lag == 0] = np.asarray(d, dtype=float)
    forced = blocks.reshape(count, size * m) @ toeplitz.transpose(1, 2, 0).reshape(size * m,
                                                                                   size)
    # the state one block on: Φ^L x + Σ_j Φ^{L−1−j} Γ u(j)
    reach = np.einsum("jnk,km->jmn", powers[size - 1::-1], gamma).reshape(size * m, n)
    pushed = blocks.reshape(count, size * m) @ reach
    starts = np.empty((count, n))
    x = np.zeros(n) if x0 is None else np.asarray(x0, dtype=float)
    step = powers[size]
    for k in range(count):
        starts[k] = x
        x = step @ x + pushed[k]
    y = forced + starts @ rows.T
    return y.reshape(-1)[:total]


def run_out_samples(models, program_samples: int) -> int:
    """Samples after the program's end for the slowest axis to settle: until its slowest
    mode has decayed by :data:`RUN_OUT_DECAY`, at most the program's own length (and at
    least one sample).

    Raises
    ------
    UnstableAxis
        An axis with spectral radius ≥ 1.
    """
    worst = 0.0
    for model in models:
        rho = model.spectral_radius
        if not rho < 1:
            raise UnstableAxis(f"closed loop unstable at T = {model.period:.6g} s "
                               f"(spectral radius {rho:.6g})")
        worst = max(worst, rho)
    if worst == 0.0:
        return 1
    need = math.ceil(math.log(RUN_OUT_DECAY) / math.log(worst))
    return max(1, min(need, max(program_samples, 1)))


def axis_inputs(reference: np.ndarray) -> np.ndarray:
    """[r(k), r(k+1)] of one axis' reference (N,), the last held (N, 2)."""
    ahead = np.append(reference[1:], reference[-1])
    return np.column_stack([reference, ahead])


def rest_state(model: AxisModel, position: float) -> np.ndarray:
    """The state at rest with the reference held at ``position`` [m]: the tool starts
    at the path's first point, (I − Φ) x = (Γ_r(k) + Γ_r(k+1)) r."""
    return np.linalg.solve(np.eye(len(model.phi)) - model.phi,
                           (model.gamma[:, 0] + model.gamma[:, 1]) * position)


def simulate_independent(models, reference: np.ndarray) -> np.ndarray:
    """Positions [m] (N, axes) of independent axes following ``reference`` [m] (N, axes),
    each starting at rest at the reference's first point."""
    out = np.empty_like(reference)
    for i, model in enumerate(models):
        u = axis_inputs(reference[:, i])
        out[:, i] = simulate_lti(model.phi, model.gamma[:, :2], model.c,
                                 np.array([model.d, 0.0]), u,
                                 x0=rest_state(model, reference[0, i]))
    return out


@dataclass(frozen=True)
class CrossCoupling:
    """Koren's cross-coupled controller (1980), on the contour-error estimate.

    ε(k) = n(k)ᵀE(k) + κ(k)(t(k)ᵀE(k))²/2, E = r − y the x and y following errors [m], t
    and n the path's unit tangent and left normal in XY at the reference, κ the signed
    curvature [1/m] (0 on a line; ±1/R on an arc, + counter-clockwise). On a line this is
    Koren's ε = −E_x sin θ + E_y cos θ; on an arc the second-order term is his circular
    form (the distance from the circle to second order in E). A PI on ε,
    w(k) = K_c (ε(k) + (T/T_i) Σ_{j≤k} ε(j)), corrects both axes along the normal,
    c_x = −w sin θ, c_y = w cos θ, added to their references. A z axis is not coupled
    (Koren's controller is biaxial, in the plane of the contour).

    Attributes
    ----------
    gain : float
        K_c [1].
    integral_time : float or None
        T_i [s]; None: a P controller.
    """

    gain: float
    integral_time: float | None = None


def simulate_coupled(models, reference: np.ndarray, tangent: np.ndarray,
                     curvature: np.ndarray, ccc: CrossCoupling) -> np.ndarray:
    """Positions [m] (N, axes) of the axes coupled by a cross-coupled controller.

    The coupled loop is one state space, [x_1, …, x_a, the PI's sum]; its matrices depend
    on the path direction at each sample, so it is stepped sample by sample (numpy per
    sample; see benchmarks/README.md for its cost against :func:`simulate_independent`).

    Parameters
    ----------
    tangent : ndarray (N, 3)
        Unit tangent of the path at each reference sample (zero where the reference stands).
    curvature : ndarray (N,)
        Signed curvature [1/m] there.
    """
    total, count = reference.shape
    sizes = [len(m.phi) for m in models]
    offsets = np.concatenate([[0], np.cumsum(sizes)])
    n = int(offsets[-1])
    phi = np.zeros((n, n))
    g_ref = np.zeros((n, 2 * count))
    g_cor = np.zeros((n, count))
    c_all = np.zeros((count, n))
    d_all = np.array([m.d for m in models])
    for i, m in enumerate(models):
        s = slice(offsets[i], offsets[i + 1])
        phi[s, s] = m.phi
        g_ref[s, 2 * i:2 * i + 2] = m.gamma[:, :2]
        g_cor[s, i] = m.gamma[:, 2]
        c_all[i, s] = m.c
    period = models[0].period
    ratio = period / ccc.integral_time if ccc.integral_time else 0.0
    ahead = np.vstack([reference[1:], reference[-1:]])
    inputs = np.empty((total, 2 * count))
    inputs[:, 0::2], inputs[:, 1::2] = reference, ahead
    driven = inputs @ g_ref.T  # the references' push on the state, every sample at once
    planar = np.array(tangent[:, :2], dtype=float)
    length = np.hypot(planar[:, 0], planar[:, 1])
    planar[length > 0] /= length[length > 0, None]
    normal = np.column_stack([-planar[:, 1], planar[:, 0]])  # the left normal n in XY
    x = np.concatenate([rest_state(m, reference[0, i]) for i, m in enumerate(models)])
    integral = 0.0
    out = np.empty((total, count))
    correction = np.zeros(count)
    gain = ccc.gain
    for k in range(total):
        y = c_all @ x + d_all * reference[k]
        out[k] = y
        error = reference[k, :2] - y[:2]
        along = planar[k] @ error
        estimate = normal[k] @ error + 0.5 * curvature[k] * along * along
        integral += estimate
        correction[:2] = gain * (estimate + ratio * integral) * normal[k]
        x = phi @ x + driven[k] + g_cor @ correction
    return out
