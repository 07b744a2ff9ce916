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
states are a recursion (an LTI system in the block index, simulated by blocks again when
the blocks are many). This is the state recursion reorganised, not
an approximation: it agrees with the per-sample recursion to rounding
(``tests/unit/machine/test_simulate.py``). Cross-coupled axes are the independent
axes' response plus the response to the correction (the loops are linear), the latter an
affine recursion whose matrix follows the path's direction, simulated by blocks too
(:func:`simulate_coupled`; Newton passes for the estimate's quadratic arc term).

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
#: the cross-coupled loop's Newton passes stop when no position moves by more than this
#: [m]: 1e-4 of a 1 µm BLU, far below any contour error reported, far above rounding
NEWTON_TOL = 1e-10
#: Newton passes at most before :func:`simulate_coupled` falls back to the per-sample
#: recursion [count]
NEWTON_STEPS = 30


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
    x = np.zeros(n) if x0 is None else np.asarray(x0, dtype=float)
    starts = _block_starts(powers[size], pushed, x, block)
    y = forced + starts @ rows.T
    return y.reshape(-1)[:total]


def _block_starts(step: np.ndarray, pushed: np.ndarray, x0: np.ndarray,
                  block: int) -> np.ndarray:
    """The states s_b (count, n) of s_{b+1} = Φ^L s_b + p_b from s_0 = ``x0``: itself an
    LTI recursion (inputs p_b, state read out row by row), so many blocks are simulated
    by :func:`simulate_lti` in blocks again; few by a loop."""
    count, n = pushed.shape
    if count <= 4 * block:
        starts = np.empty((count, n))
        x = x0
        for k in range(count):
            starts[k] = x
            x = step @ x + pushed[k]
        return starts
    eye = np.eye(n)
    return np.column_stack([simulate_lti(step, eye, eye[i], np.zeros(n), pushed, x0=x0,
                                         block=block) for i in range(n)])


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
        x0 = rest_state(model, reference[0, i])
        if model.continuous:
            out[:, i] = simulate_lti(model.phi, model.gamma[:, :2], model.c,
                                     np.array([model.d, 0.0]), axis_inputs(reference[:, i]),
                                     x0=x0)
        else:  # a sampled loop reads r(k) only (its r(k + 1) column is zero)
            out[:, i] = simulate_lti(model.phi, model.gamma[:, :1], model.c,
                                     np.array([model.d]), reference[:, i, None], x0=x0)
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


def _normal_frame(tangent: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit tangent t and left normal n in XY (N, 2) of the path's tangent (N, 3); zero
    where the tangent has no XY part."""
    planar = np.array(tangent[:, :2], dtype=float)
    length = np.hypot(planar[:, 0], planar[:, 1])
    planar[length > 0] /= length[length > 0, None]
    return planar, np.column_stack([-planar[:, 1], planar[:, 0]])


def simulate_coupled(models, reference: np.ndarray, tangent: np.ndarray,
                     curvature: np.ndarray, ccc: CrossCoupling) -> np.ndarray:
    """Positions [m] (N, axes) of the axes coupled by a cross-coupled controller,
    vectorised (no Python loop per sample).

    The loop is linear in the references, so the positions are the independent axes'
    (:func:`simulate_independent`) plus each coupled axis' response to the correction
    alone, from rest. The correction's loop has the state S = [z_x, z_y, I] (the x and
    y loops' responses to their corrections, the PI's sum), and per sample

        ε(k) = a(k)ᵀ(E₀(k) − [C_x z_x(k), C_y z_y(k)]) + b(k),  I ← I + ε,
        w = K_c (ε + (T/T_i) I),  z_i(k+1) = Φ_i z_i(k) + Γ_{c,i} n_i(k) w(k),

    an affine recursion S(k+1) = A(k)S(k) + u(k) whose matrix changes with the direction
    (E₀ the independent axes' following errors). On a line a(k) = n and b = 0: the
    estimate is linear and this is the exact loop. On an arc the estimate's term
    κ(tᵀE)²/2 is quadratic; it is linearised at the last iterate's error E₁,
    a = n + κ(tᵀE₁)t, b = −κ(tᵀE₁)²/2, and the recursion repeated (Newton's method on the
    whole trajectory, quadratic convergence) until the positions move, or would move at
    the last passes' rate of contraction, by less than :data:`NEWTON_TOL`. Each pass is a blocked exact recursion: the samples are cut into
    blocks of L, every block's map composed with numpy over all blocks at once (L steps),
    the block-start states chained (one step per block), and the states inside every
    block recovered (L steps again): 2L + N/L numpy steps instead of N Python ones.
    It agrees with the per-sample recursion (:func:`simulate_coupled_stepped`) to
    rounding (``tests/unit/machine/test_simulate.py``); should Newton not converge in
    :data:`NEWTON_STEPS` passes, the per-sample recursion answers.

    Parameters
    ----------
    models : list of AxisModel
    reference : ndarray (N, axes)
        Each axis' position reference [m].
    tangent : ndarray (N, 3)
        Unit tangent of the path at each reference sample (zero where the reference stands).
    curvature : ndarray (N,)
        Signed curvature [1/m] there.
    ccc : CrossCoupling
    """
    independent = simulate_independent(models, reference)
    if reference.shape[0] == 0:
        return independent
    planar, normal = _normal_frame(tangent)
    curvature = np.asarray(curvature, dtype=float)
    base_error = reference[:, :2] - independent[:, :2]
    arcs = np.any(curvature != 0)
    shift = np.zeros((len(reference), 2))
    loop = _CorrectionLoop(models[:2], ccc, normal)
    previous = math.inf
    for _ in range(NEWTON_STEPS):
        along = np.einsum("ij,ij->i", planar, base_error - shift)
        weight = normal + (curvature * along)[:, None] * planar
        offset = -0.5 * curvature * along * along
        moved = loop.response(weight, np.einsum("ij,ij->i", weight, base_error) + offset)
        change = float(np.max(np.abs(moved - shift)))
        shift = moved
        # this pass moved the positions by `change`; the next would move them by about
        # change·(change/previous) or less once the passes contract (Newton: far less)
        if not arcs or not change > NEWTON_TOL or (
                change < previous < math.inf and change * change / previous <= NEWTON_TOL):
            break  # exact (linear), converged, or diverged (an unstable coupled loop)
        previous = change
    else:
        return simulate_coupled_stepped(models, reference, tangent, curvature, ccc)
    out = independent.copy()
    out[:, :2] += shift
    return out


class _CorrectionLoop:
    """The x and y loops' responses [m] (N, 2), from rest, to the correction w n of the
    affine loop ε(k) = f(k) − a(k)ᵀ[C_x z_x(k), C_y z_y(k)], I ← I + ε,
    w = K_c(ε + (T/T_i) I), by the blocked recursion of :func:`simulate_coupled`.

    Per-sample arrays are laid out (L, blocks, ·): step j of every block at once is one
    contiguous slice."""

    def __init__(self, models, ccc: CrossCoupling, normal: np.ndarray):
        self.total = total = len(normal)
        sizes = [len(m.phi) for m in models]
        self.n = n = sum(sizes)
        self.phi_t = np.zeros((n, n))
        feed = np.zeros((total, n))  # Γ_{c,i} n_i(k)
        self.c = np.zeros((2, n))
        at = 0
        for i, (m, s) in enumerate(zip(models, sizes)):
            self.phi_t[at:at + s, at:at + s] = m.phi.T
            feed[:, at:at + s] = normal[:, i, None] * m.gamma[:, 2]
            self.c[i, at:at + s] = m.c
            at += s
        self.gain = ccc.gain
        self.ratio = models[0].period / ccc.integral_time if ccc.integral_time else 0.0
        self.length = max(8, int(math.sqrt(total / 2)))
        self.count = -(-total // self.length)
        self.feed = self._blocked(feed)

    def _blocked(self, values: np.ndarray) -> np.ndarray:
        """(N, ·) → (L, blocks, ·), zero-padded."""
        padded = np.zeros((self.count * self.length,) + values.shape[1:])
        padded[:self.total] = values
        shape = (self.count, self.length) + values.shape[1:]
        return np.ascontiguousarray(np.swapaxes(padded.reshape(shape), 0, 1))

    def _step(self, z, total_sum, lift, probe, forcing, feed):
        """One sample on for every block: z (B, c, n), the PI's sum (B, c) and the
        homogeneous coordinate (B, c) of c state vectors per block."""
        eps = np.einsum("bcn,bn->bc", z, probe) + lift * forcing[:, None]
        total_sum = total_sum + eps
        w = self.gain * (eps + self.ratio * total_sum)
        shape = z.shape
        z = (z.reshape(-1, self.n) @ self.phi_t).reshape(shape) + feed[:, None, :] * w[:, :, None]
        return z, total_sum

    def response(self, weight: np.ndarray, forcing: np.ndarray) -> np.ndarray:
        probe = self._blocked(-(weight[:, 0, None] * self.c[0] + weight[:, 1, None] * self.c[1]))
        forcing = self._blocked(forcing)
        n, count, size = self.n, self.count, self.n + 2
        # every block's map of its start state [z, I, 1] to its end state
        eye = np.broadcast_to(np.eye(size), (count, size, size))
        z, total_sum, lift = eye[:, :, :n].copy(), eye[:, :, n].copy(), eye[:, :, n + 1]
        for j in range(self.length):
            z, total_sum = self._step(z, total_sum, lift, probe[j], forcing[j], self.feed[j])
        maps = np.concatenate([z, total_sum[:, :, None], lift[:, :, None]], axis=2)
        starts = np.empty((count, size))
        state = np.zeros(size)
        state[-1] = 1.0
        for b in range(count):
            starts[b] = state
            state = state @ maps[b]
        z, total_sum, lift = starts[:, None, :n], starts[:, None, n], starts[:, None, n + 1]
        y = np.empty((self.length, count, 2))
        for j in range(self.length):
            y[j] = z[:, 0] @ self.c.T
            z, total_sum = self._step(z, total_sum, lift, probe[j], forcing[j], self.feed[j])
        return np.swapaxes(y, 0, 1).reshape(-1, 2)[:self.total]


def simulate_coupled_stepped(models, reference: np.ndarray, tangent: np.ndarray,
                             curvature: np.ndarray, ccc: CrossCoupling) -> np.ndarray:
    """:func:`simulate_coupled` by the coupled loop's state recursion stepped sample by
    sample (numpy per sample), the nonlinear estimate evaluated as it stands: the
    definition the vectorised one is held to, and its fallback.
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
    planar, normal = _normal_frame(tangent)
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
