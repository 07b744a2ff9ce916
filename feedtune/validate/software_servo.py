"""An independent numpy/scipy model of the ``software_servo`` plant (no CasADi, no
feedtune.loops.loop).

Written from the papers, not from :mod:`feedtune.loops.loop`:

* ``reference_pulse`` (Koren 1979 eqs 3–7): open loop K/(s(1 + sτ)), closed loop
  ẍ + ẋ/τ + (K/τ)x = (K/τ)r, states [x, ẋ];
* ``sampled_data`` (Koren 1979 Fig 4, eqs 12–19; Sato eq 1): the drive 1/(s(1 + sτ)), or
  1/s without τ (Sato's ideal drive), behind a zero-order hold; every T the error
  e(n) = r − x(nT) times K is the command c(n), applied ``delay`` whole samples later.
  The plant is discretised exactly with :func:`scipy.linalg.expm` of the augmented matrix
  [[A, B], [0, 0]]·T (Van Loan), not with the closed-form Φ, Γ of the tuner.

What it measures, all on floats:

* :meth:`ServoModel.poles`: closed-loop poles (s-plane or z-plane);
* :meth:`ServoModel.equivalent_pair`: (ζ, ω_n) of the closed-loop pole pair, through
  s = ln(z)/T for a sampled loop (Koren eq 19);
* :meth:`ServoModel.error_integrals`: IAE, ISE, ITAE of the error after a unit position
  step, exact to rounding: sampled, sample by sample from the exact state at the samples
  (Van Loan's integrals of the drive's free motion, |e| split at its zeros between
  samples); reference pulse, in closed form from the zeros of the second-order error;
* :meth:`ServoModel.ramp_following_error`: steady error after a unit ramp, at the samples
  (the velocity constant is its inverse);
* :meth:`ServoModel.sensitivity`: S = 1/(1 + L) on any frequency grid from the open loop
  L(jω) or L(e^{jωT}) = K·z^{−d}·G_ZOH(z) (a formulation the tuner does not use);
* :meth:`ServoModel.radial_error`: r·| |H| − 1 | of a circle at ω = feed/r, H = L/(1 + L),
  without the cancellation of |H| − 1;
* :meth:`ServoModel.circle_test`: the two-axis circle test in the time domain (the circle
  or Sato's interpolated polygon as reference, simulated until the transient is gone),
  which re-measures the circle metrics and is checked against the frequency response;
* :meth:`ServoModel.responses`: step and ramp responses for the report.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.linalg import expm
from scipy.linalg.lapack import zgesv
from scipy.optimize import brentq, minimize_scalar

from feedtune.validate import sampled_frequency
from feedtune.validate.continuous import PAIR_MEASUREMENTS, ContinuousModel, siso
from feedtune.validate.integrals import error_integrals
from feedtune.validate.measurements import Measurement, Phase, measure_entries
from feedtune.validate.model import CircleTrace, NotCovered, Response
from feedtune.validate.tolerances import Context

#: the minimum radius is judged on the radii where the error at V_m is BLU/2 ± this (in BLU)
CRITERION_BAND = 1e-3
#: radii scanned for the minimum radius: this many per decade, over MIN_RADIUS_SPAN decades
#: from V_m/C_v up (ω from C_v down)
RADII_PER_DECADE, MIN_RADIUS_SPAN = 400, 4
#: times the scan may grow by MIN_RADIUS_SPAN decades while its largest radius still fails
MIN_RADIUS_EXTENSIONS = 3

#: the simulated step response runs until the free response has decayed to this fraction
SETTLED = 1e-13
#: sub-steps per sample (sampled) or per block (continuous) of the dense simulation
SUBSTEPS = 256
#: sub-steps per sample in the circle test (continuous loops: 16 times this per revolution)
CIRCLE_SUBSTEPS = 64
#: at most this many samples/blocks are simulated (a nearly undamped loop is refused)
MAX_BLOCKS = 200_000
#: at most this many Newton steps for a zero of the error inside a sample (it converges
#: monotonically, quadratically near the zero: ≈ 5 steps)
NEWTON_STEPS = 60


@dataclass(frozen=True)
class ServoModel:
    """A software servo with numbers: gain K [1/s], τ [s] or None, T [s] or None."""

    gain: float
    time_constant: float | None
    period: float | None = None  # None: the continuous reference-pulse loop
    delay: int = 0
    position_unit: str = "m"
    #: Sato's linear interpolator: a vertex on the path every T [s]; None: no interpolator
    reference_interval: float | None = None
    #: Koren's BLU [m] and maximum velocity V_m [m/s] (min_radius), when the spec gives them
    blu: float | None = None
    max_velocity: float | None = None

    @classmethod
    def from_result(cls, plant: dict, tuned: dict, stability: dict | None = None) -> "ServoModel":
        """The model of a result's plant spec and tuned values (floats)."""
        if plant.get("type") != "software_servo":
            raise NotCovered(f"plant type {plant.get('type')!r} is not modelled by the validator")
        gain = float(tuned["position_gain"])
        koren = {"blu": plant.get("blu"), "max_velocity": plant.get("max_velocity")}
        if plant["technique"] == "reference_pulse":
            return cls(gain, float(plant["time_constant"]), **koren)
        tau = plant.get("time_constant")
        interval = (float(tuned["reference_interval"])
                    if plant.get("interpolation", "none") == "linear" else None)
        if plant.get("model", "exact") == "pade":
            return PadeServoModel(gain, None if tau is None else float(tau),
                                  float(tuned["sampling_period"]),
                                  int(plant.get("computation_delay", 0)), interval,
                                  plant.get("blu"))
        return cls(gain, None if tau is None else float(tau), float(tuned["sampling_period"]),
                   int(plant.get("computation_delay", 0)), reference_interval=interval, **koren)

    @property
    def sampled(self) -> bool:
        return self.period is not None

    # -- the continuous drive ----------------------------------------------------------

    def drive_matrices(self):
        """(A, B, C) of the drive, velocity command → position: 1/s or 1/(s(1 + sτ))."""
        if self.time_constant is None:
            return np.zeros((1, 1)), np.ones((1, 1)), np.ones((1, 1))
        tau = self.time_constant
        return (np.array([[0.0, 1.0], [0.0, -1.0 / tau]]), np.array([[0.0], [1.0 / tau]]),
                np.array([[1.0, 0.0]]))

    @functools.lru_cache(maxsize=8)
    def zoh(self, step: float):
        """Exact ZOH discretisation over ``step`` [s]: (Φ, Γ) from expm([[A, B], [0, 0]]·step)."""
        a, b, _ = self.drive_matrices()
        m = a.shape[0]
        big = np.zeros((m + 1, m + 1))
        big[:m, :m], big[:m, m:] = a, b
        e = expm(big * step)
        return e[:m, :m], e[:m, m:]

    # -- closed loop -------------------------------------------------------------------

    def closed_loop(self):
        """(F, G) with state' = F state + G r (continuous) or state(n+1) = F state(n) + G r.

        Sampled state: [drive states, c(n−1), ..., c(n−d)]; the command held over sample n
        is c(n − d), c(n) = K(r − x(nT)).
        """
        f, g = self._closed_loop()
        return f.copy(), g.copy()

    @functools.lru_cache(maxsize=8)
    def _closed_loop(self):
        """:meth:`closed_loop`, built once per model (its measurements ask ≈ 10 times)."""
        k = self.gain
        a, b, c = self.drive_matrices()
        m = a.shape[0]
        if not self.sampled:
            return a - k * b @ c, k * b
        phi, gamma = self.zoh(self.period)
        d = self.delay
        n = m + d
        f = np.zeros((n, n))
        g = np.zeros((n, 1))
        f[:m, :m] = phi
        if d == 0:
            f[:m, :m] -= k * gamma @ c
            g[:m] = k * gamma
        else:
            f[:m, n - 1:n] = gamma  # the oldest command c(n − d) is applied now
            f[m, :m] = -k * c[0]  # c(n) = K(r − x)
            g[m, 0] = k
            for i in range(1, d):
                f[m + i, m + i - 1] = 1.0
        return f, g

    def poles(self) -> np.ndarray:
        """Closed-loop poles [1/s] (continuous) or [1] (z-plane)."""
        return self._poles().copy()

    @functools.lru_cache(maxsize=8)
    def _poles(self) -> np.ndarray:
        return np.linalg.eigvals(self._closed_loop()[0])

    def stable(self) -> bool:
        p = self.poles()
        return bool(np.max(np.abs(p)) < 1) if self.sampled else bool(np.max(p.real) < 0)

    def context(self) -> Context:
        """The physical scales: the BLU [m] and the slowest time constant 1/min|s| [s]
        (s = ln z / T for a sampled loop; z = 0 poles, the delay buffer, have none)."""
        return self._context

    @functools.cached_property
    def _context(self) -> Context:
        """:meth:`context`, once per model (a frozen Context): the model's table and its
        pole rows each judge on it."""
        p = self.poles().astype(complex)
        if self.sampled:
            p = np.log(p[np.abs(p) > 1e-12]) / self.period
        speeds = np.abs(p)
        speeds = speeds[speeds > 0]
        return Context(blu=self.blu, time=1.0 / float(np.min(speeds)) if speeds.size else None,
                       position_unit=self.position_unit)

    def equivalent_pair(self) -> tuple[float, float]:
        """(ζ, ω_n [rad/s]) of a second-order loop: s-plane poles s1, s2 (s = ln(z)/T when
        sampled, Koren eqs 17–19), ω_n = √(s1 s2), ζ = −(s1 + s2)/(2ω_n). A negative real
        z-pole rings at the Nyquist frequency: s = ln|z| ± jπ/T of the most negative one."""
        p = self.poles()
        if self.sampled:
            return sampled_pole_pair(p, self.period)
        if p.size != 2:
            raise NotCovered(f"ζ and ω_n need a second-order loop (order {p.size})")
        return _pair(p.astype(complex))

    # -- time responses ----------------------------------------------------------------

    def _block(self) -> float:
        """Length of one simulation block [s]: T, or a tenth of the fastest time scale."""
        if self.sampled:
            return self.period
        return 0.1 / float(np.max(np.abs(self.poles())))

    def _blocks_to_settle(self, f_block: np.ndarray | None = None) -> int:
        """Blocks until the free response has decayed to SETTLED, from the spectral radius
        of ``f_block``, the state's transition over one block; None: the sampled loop's
        F, whose eigenvalues are the poles (:meth:`poles`, once per model)."""
        eigenvalues = self._poles() if f_block is None else np.linalg.eigvals(f_block)
        radius = float(np.max(np.abs(eigenvalues)))
        if radius >= 1:
            raise ValueError("unstable loop: the step response does not settle")
        blocks = math.ceil(math.log(SETTLED) / math.log(radius)) + 10
        if blocks > MAX_BLOCKS:
            raise ValueError(f"the step response needs {blocks} blocks (limit {MAX_BLOCKS})")
        return blocks

    def step_error(self, substeps: int = SUBSTEPS):
        """(t, e): the error 1 − x(t) after a unit step on a dense grid, every block cut into
        ``substeps``; exact at every grid point (expm of the augmented matrix). The
        report's curves (:meth:`responses`); :meth:`error_integrals` needs no grid."""
        h = self._block()
        a, b, c = self.drive_matrices()
        m = a.shape[0]
        if not self.sampled:
            # continuous closed loop: x(t) from expm(F·jh/substeps) applied to the block state
            f, g = self.closed_loop()
            big = np.zeros((m + 1, m + 1))
            big[:m, :m], big[:m, m:] = f, g
            rows = _first_rows(expm(big * h / substeps), substeps)  # position per sub-step
            blocks = self._blocks_to_settle(expm(f * h))
            state = np.zeros(m + 1)
            state[m] = 1.0  # the reference, constant
            starts = _orbit(expm(big * h), state, blocks)
        else:
            f, g = self.closed_loop()
            blocks = self._blocks_to_settle()
            n = f.shape[0]
            # the command held over sample i: K(1 − x) without delay, else the buffer's last
            if self.delay == 0:
                kx = np.concatenate([-self.gain * c[0], np.zeros(n - m)])
                kr = self.gain
            else:
                kx = np.zeros(n)
                kx[n - 1] = 1.0
                kr = 0.0
            big = np.zeros((m + 1, m + 1))
            big[:m, :m], big[:m, m:] = a, b
            rows = _first_rows(expm(big * h / substeps), substeps)
            # state(i + 1) = F state(i) + G from 0: the orbit of [state, 1] under [[F, G], [0, 1]]
            affine = np.zeros((n + 1, n + 1))
            affine[:n, :n], affine[:n, n], affine[n, n] = f, g[:, 0], 1.0
            start = np.zeros(n + 1)
            start[n] = 1.0
            states = _orbit(affine, start, blocks)[:, :n]
            held = states @ kx + kr
            starts = np.column_stack([states[:, :m], held])  # [drive states, u] per sample
        positions = starts @ rows.T  # (blocks, substeps)
        t = (np.arange(blocks)[:, None] * h + np.arange(substeps)[None, :] * h / substeps)
        e = 1.0 - positions
        return t.ravel(), e.ravel(), h / substeps

    def error_integrals(self) -> dict[str, float]:
        """IAE [m·s], ISE [m²·s], ITAE [m·s²] after a unit step, exact to rounding: the
        sampled loop sample by sample (:meth:`_sampled_error_integrals`), the reference
        pulse loop in closed form (:meth:`_continuous_error_integrals`)."""
        if self.sampled:
            return self._sampled_error_integrals()
        return self._continuous_error_integrals()

    def _continuous_error_integrals(self) -> dict[str, float]:
        """IAE, ISE, ITAE after a unit step of the reference-pulse loop in closed form.

        The error obeys ë + 2ζω_n ė + ω_n² e = 0, e(0) = 1, ė(0) = 0 (Koren eqs 3–7:
        ω_n² = K/τ, 2ζω_n = 1/τ). Integrating the equation, once and times t, over an
        interval whose ends are zeros of e (or 0 and a zero) gives ∫e and ∫t·e from ė
        there: ISE = (1 + 4ζ²)/(4ζω_n) = (τ + 1/K)/2 for any ζ; without zeros (ζ ≥ 1)
        IAE = ∫e = 2ζ/ω_n = 1/K and ITAE = (4ζ² − 1)/ω_n². Underdamped, e =
        e^{−σt}(cos ω_d t + (σ/ω_d) sin ω_d t), σ = 1/(2τ): its zeros t_j = t_0 + jπ/ω_d,
        t_0 = (π/2 + atan(σ/ω_d))/ω_d, where ė = −ω_n e^{−σt_0}(−q)^j, q = e^{−σπ/ω_d};
        the lobes are geometric series. The loop must still settle within MAX_BLOCKS
        blocks (:meth:`_blocks_to_settle`), the refusal of the dense simulation."""
        f, _ = self._closed_loop()
        self._blocks_to_settle(expm(f * self._block()))
        k, tau = self.gain, self.time_constant
        wn2 = k / tau
        ise = (tau + 1 / k) / 2
        wd2 = (4 * k * tau - 1) / (4 * tau * tau)  # ω_d² = ω_n² − σ²
        if wd2 <= 0:
            return {"iae": 1 / k, "ise": ise, "itae": (1 - k * tau) / (k * k)}
        sigma, wd, wn = 1 / (2 * tau), math.sqrt(wd2), math.sqrt(wn2)
        t0 = (math.pi / 2 + math.atan(sigma / wd)) / wd
        slope = -wn * math.exp(-sigma * t0)  # ė(t_0)
        q = math.exp(-sigma * math.pi / wd)
        rest = -math.expm1(-sigma * math.pi / wd)  # 1 − q
        two_zeta_wn = 1 / tau
        first = (two_zeta_wn - slope) / wn2  # ∫₀^{t_0} e
        iae = first - slope * (1 + q) / (rest * wn2)
        first_moment = -(t0 * slope + 1 - two_zeta_wn * first) / wn2  # ∫₀^{t_0} t·e
        span = math.pi / wd
        lobes = -slope / wn2 * (t0 * (1 + q) / rest + 2 * span * q / rest**2
                                + two_zeta_wn * (1 + q) / (rest * wn2))
        return {"iae": iae, "ise": ise, "itae": first_moment + lobes}

    @functools.lru_cache(maxsize=8)
    def _sample_integral_matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(J1, J2, Q) of one sample, h = T, for the drive with its held command as a
        state, w' = M w, M = [[A, B], [0, 0]]: J1 = ∫₀ʰ e^{Ms} ds, J2 = ∫₀ʰ s·e^{Ms} ds and
        Q = ∫₀ʰ e^{Mᵀs} pᵀp e^{Ms} ds (p picks the position), each from one expm of an
        augmented matrix (Van Loan 1978, IEEE TAC 23(3), eqs 1.1–1.2): expm of
        [[M, I, 0], [0, 0, I], [0, 0, 0]]·h holds J1 and ∫₀ʰ (h − s) e^{Ms} ds = h·J1 − J2;
        expm of [[−Mᵀ, pᵀp], [0, M]]·h holds e^{Mh} and e^{−Mᵀh}Q."""
        a, b, _ = self.drive_matrices()
        m, h = a.shape[0], self.period
        k = m + 1
        big = np.zeros((k, k))
        big[:m, :m], big[:m, m:] = a, b
        chain = np.zeros((3 * k, 3 * k))
        chain[:k, :k] = big
        chain[:k, k:2 * k] = chain[k:2 * k, 2 * k:] = np.eye(k)
        e = expm(chain * h)
        j1 = e[:k, k:2 * k]
        j2 = h * j1 - e[:k, 2 * k:]
        weight = np.zeros((k, k))
        weight[0, 0] = 1.0
        gram = np.zeros((2 * k, 2 * k))
        gram[:k, :k], gram[:k, k:], gram[k:, k:] = -big.T, weight, big
        e = expm(gram * h)
        return j1, j2, e[k:, k:].T @ e[:k, k:]

    def _sampled_error_integrals(self) -> dict[str, float]:
        """IAE, ISE, ITAE after a unit step of the sampled loop, exact to rounding.

        The loop's state is exact at every sample (the orbit of the deviation from the
        final state [1, 0, …] under F: no 1 − x cancellation), and over sample k the
        drive moves freely with the held command u_k: w(s) = e^{Ms} w_k, e(s) = −x̃(s) =
        −p·w(s), w = [x̃ (, ẋ), u] (:meth:`_sample_integral_matrices`). So ∫e = −p J1 w_k,
        ∫s·e = −p J2 w_k and ∫e² = w_kᵀ Q w_k over the sample. Where e keeps its sign
        over a sample, ∫|e| = |∫e| and ∫(t_k + s)|e| = |t_k ∫e + ∫s·e|. In between e is
        the drive's free motion, x̃(s) = x̃_k + u s + (ẋ_k − u)·τ(1 − e^{−s/τ}) (linear
        without τ): convex or concave, so it has at most two zeros, one on each side of
        its extremum (where ẋ = 0, s* = τ ln((u − ẋ_k)/u), only when ẋ changes sign in
        the sample); a zero is found by Newton's method from the end where e·e'' > 0
        (monotone convergence), and the sample is integrated piecewise by the closed
        forms of ∫x̃ and ∫s·x̃. Samples from 0 until the free response has decayed to
        SETTLED (:meth:`_blocks_to_settle`)."""
        f, _ = self._closed_loop()
        blocks = self._blocks_to_settle()
        h, tau, m = self.period, self.time_constant, self.drive_matrices()[0].shape[0]
        start = np.zeros(f.shape[0])
        start[0] = -1.0  # x = 0 against the final 1; speeds and held commands 0
        states = _orbit(f, start, blocks + 1)
        held = -self.gain * states[:, 0] if self.delay == 0 else states[:, -1]
        w = np.column_stack([states[:, :m], held])
        j1, j2, q = self._sample_integral_matrices()
        first = -(w[:-1] @ j1[0])  # ∫e over each sample
        moment = -(w[:-1] @ j2[0])  # ∫s·e
        squares = np.einsum("ki,ij,kj->k", w[:-1], q, w[:-1])
        times = np.arange(blocks) * h
        timed = times * first + moment
        x0, x1, u = w[:-1, 0], w[1:, 0], held[:-1]
        v0 = w[:-1, 1] if m == 2 else None
        # the extremum inside a sample: ẋ changes sign (two states only)
        turns = np.zeros(blocks, dtype=bool) if m == 1 else (v0 * w[1:, 1] < 0)
        if m == 2:
            s_turn = np.full(blocks, h)
            s_turn[turns] = np.clip(tau * np.log1p(-v0[turns] / u[turns]), 0.0, h)
            x_turn = np.full(blocks, np.nan)
            x_turn[turns] = _free_position(x0[turns], v0[turns], u[turns], tau, s_turn[turns])
            first_side = np.where(turns, x_turn, x1)
            crossing = (x0 * first_side < 0) | (turns & (x_turn * x1 < 0))
        else:
            crossing = x0 * x1 < 0
        iae = float(np.sum(np.abs(first[~crossing])))
        itae = float(np.sum(np.abs(timed[~crossing])))
        idx = np.flatnonzero(crossing)
        if idx.size:
            x0c, x1c, uc, tc = x0[idx], x1[idx], u[idx], times[idx]
            v0c = None if m == 1 else v0[idx]
            if m == 1:
                r1, r2 = np.clip(x0c / -uc, 0.0, h), np.full(idx.size, h)
            else:
                sc, xtc, turned = s_turn[idx], x_turn[idx], turns[idx]
                end1 = np.where(turned, xtc, x1c)
                has1 = x0c * end1 < 0
                has2 = turned & (xtc * x1c < 0)
                r1 = np.zeros(idx.size)
                r2 = np.full(idx.size, h)
                r1[has1] = _free_zero(x0c[has1], v0c[has1], uc[has1], tau,
                                      np.zeros(has1.sum()), sc[has1])
                r2[has2] = _free_zero(x0c[has2], v0c[has2], uc[has2], tau, sc[has2],
                                      np.full(has2.sum(), h))
            cuts = [np.zeros(idx.size), r1, r2, np.full(idx.size, h)]
            prims = [_free_integrals(x0c, v0c, uc, tau, s) for s in cuts]
            for (a1, a2), (b1, b2) in zip(prims[:-1], prims[1:]):
                iae += float(np.sum(np.abs(b1 - a1)))
                itae += float(np.sum(np.abs(tc * (b1 - a1) + (b2 - a2))))
        return {"iae": iae, "ise": float(np.sum(squares)), "itae": itae}

    def ramp_following_error(self) -> float:
        """Steady error after a unit ramp r = t [m] at the samples (continuous: any time)."""
        return self._ramp_following_error()

    @functools.lru_cache(maxsize=8)
    def _ramp_following_error(self) -> float:
        """:meth:`ramp_following_error`, once per model (C_v's entry and the minimum
        radius's scan, from V_m/C_v, both ask)."""
        # steady state of a type-1 loop under a ramp: the drive moves at 1 m/s, the error is
        # constant at the samples; the command is K·e and must equal the velocity 1
        f, g = self.closed_loop()
        if not self.sampled:
            # continuous, states [x, ẋ]: x = t − e, ẋ = 1, ẍ = 0; the second row of
            # F[x, ẋ] + G t = 0 with F[1, 0] = −G[1] (the loop is fed by r − x) gives e
            return float(-f[1, 1] / g[1, 0])
        # sampled, r(k) = kT: the steady solution state(k) = p0 + k·p1 of
        # state(k+1) = F state(k) + G kT needs p1 = F p1 + G T and p0 + p1 = F p0
        n = f.shape[0]
        p1 = np.linalg.solve(np.eye(n) - f, g[:, 0] * self.period)
        p0 = np.linalg.solve(np.eye(n) - f, -p1)
        # position at sample k: p0[0] + k p1[0] with p1[0] = T; error = kT − position
        return float(-p0[0])

    # -- frequency response ------------------------------------------------------------

    def open_loop(self, omega) -> np.ndarray:
        """L(jω) = K/(jω(1 + jωτ)), or L(e^{jωT}) = K z^{−d} C(zI − Φ)^{−1}Γ."""
        omega = np.atleast_1d(np.asarray(omega, dtype=float))
        if not self.sampled:
            s = 1j * omega
            return self.gain / (s * (1 + s * self.time_constant))
        phi, gamma, c, eye = self._resolvent_parts
        z = np.exp(1j * omega * self.period)
        resolvent = z[:, None, None] * eye - phi
        if z.size == 1:  # brentq's and Brent's calls: no stack of right-hand sides to
            # broadcast; LAPACK solves the same matrix for the same Γ, so the same bits
            out = np.linalg.solve(resolvent[0], gamma)[None, :, 0] @ c
        else:
            rhs = np.broadcast_to(gamma, (z.size, *gamma.shape))
            out = np.linalg.solve(resolvent, rhs)[:, :, 0] @ c
        return self.gain * z ** (-self.delay) * out

    def open_loop_at(self, omega: float) -> np.complex128:
        """:meth:`open_loop` at one ω [rad/s] (brentq's and Brent's calls, ≈ 65 a batch
        spec), ``open_loop(omega)[0]`` to the bit without the arrays around one value.

        The same operations on the same numbers: the same LAPACK solve of zI − Φ built by
        numpy, and numpy's own ufuncs for the steps whose rounding is numpy's (the complex
        product and quotient, whose SIMD loops may fuse a multiply and an add). Python
        floats only where the result is exact or one correctly rounded operation either
        way: e^{jωT} = cos ωT + j sin ωT (numpy's complex exp of a pure imaginary number,
        both from the C library), z^{−1} (numpy's reciprocal, the same formula), K·z^{−1}
        and C x = x₀ (C = [1, 0…]: products with 0 and 1 are exact). The solve is LAPACK's
        ``zgesv``, the routine ``np.linalg.solve`` calls, through scipy's public wrapper
        (:func:`_solve_resolvent`)."""
        if not self.sampled:
            s = 1j * omega
            return np.divide(self.gain, s * (1 + s * self.time_constant))
        if self.delay > 1:  # numpy's z**(−d) by repeated products: the array's own
            return self.open_loop(omega)[0]
        negated, gamma = self._one_frequency_parts
        y = omega * self.period
        z = complex(math.cos(y), math.sin(y))
        resolvent = negated.copy()  # zI − Φ: z added on the diagonal of −Φ, the same
        for i in range(len(resolvent)):  # numbers as z·I − Φ (z·1 and z·0 are exact)
            resolvent[i, i] += z
        position = complex(_solve_resolvent(resolvent, gamma)[0, 0])
        if self.delay == 0:
            return np.complex128(self.gain * position)
        return np.multiply(self.gain * (1 / z), position)

    @functools.cached_property
    def _resolvent_floats(self) -> tuple[list, list]:
        """(Φ's rows, Γ) of :meth:`_resolvent_parts` as Python floats
        (:func:`resolvent_position`)."""
        phi, gamma, _, _ = self._resolvent_parts
        return phi.tolist(), gamma[:, 0].tolist()

    @functools.cached_property
    def _one_frequency_parts(self) -> tuple[np.ndarray, np.ndarray]:
        """(−Φ, Γ) of :meth:`_resolvent_parts` as complex arrays, for :meth:`open_loop_at`:
        LAPACK solves zI − Φ and Γ as complex numbers either way (numpy casts a real Γ),
        built here once instead of by two array operations and a cast a call."""
        phi, gamma, _, _ = self._resolvent_parts
        return (-phi).astype(complex), gamma.astype(complex)

    @functools.cached_property
    def _resolvent_parts(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(Φ, Γ, C's row, I) of :meth:`open_loop`, once per model: brentq and bounded Brent
        call it at one ω at a time (≈ 66 calls a batch spec), where building the drive's
        matrices and looking up the ZOH each time cost as much as the solve. The same
        arrays as before, so the same numbers to the bit."""
        phi, gamma = self.zoh(self.period)
        return phi, gamma, self.drive_matrices()[2][0], np.eye(phi.shape[0])

    def frequency_response(self, omega) -> tuple[np.ndarray, np.ndarray]:
        """(L, H) at ``omega`` [rad/s] (sampled: on the unit circle, below Nyquist), L by
        :meth:`_grid_open_loop` (the frequency metrics' scan, the report's curves)."""
        lo = self._grid_open_loop(omega)
        return lo, lo / (1.0 + lo)

    def _grid_open_loop(self, omega) -> np.ndarray:
        """:meth:`open_loop` on a grid of ω [rad/s], the sampled loop's by Cramer's rule
        (:func:`resolvent_position`) instead of a LAPACK solve a frequency: the same
        quantity ≈ 1e-15 relative apart, 0.1 of the time. The scans that bracket the
        minimum radius and the frequency metrics' peaks and crossings take it; the minimum
        radius's refinements take LAPACK's :meth:`open_loop_at`, the frequency metrics'
        :meth:`frequency_response_at`."""
        if not self.sampled:
            return self.open_loop(omega)
        y = np.atleast_1d(np.asarray(omega, dtype=float)) * self.period
        z = np.empty(y.shape, dtype=complex)  # e^{jωT}: numpy's complex exp of jωT is the
        z.real, z.imag = np.cos(y), np.sin(y)  # C library's cos and sin, computed alone
        position = resolvent_position(*self._resolvent_floats, z)
        # without delay the product with z⁰ = 1 + 0j, exactly, is left out
        return self.gain * (z ** (-self.delay) if self.delay else 1) * position

    def sensitivity(self, omega) -> np.ndarray:
        """S = 1/(1 + L) = error/reference."""
        return 1.0 / (1.0 + self.open_loop(omega))

    def complementary(self, omega) -> np.ndarray:
        """H = L/(1 + L) = position/reference (at the samples when sampled)."""
        lo = self.open_loop(omega)
        return lo / (1.0 + lo)

    def frequency_response_at(self, omega: float) -> tuple[complex, complex]:
        """(L, H) at one ω [rad/s], the frequency metrics' refinements (≈ 70 calls a
        sampled spec): the sampled open loop by Cramer's rule in Python's complex numbers,
        the grid's formula (:meth:`_grid_open_loop`, :func:`resolvent_position`) without
        arrays, ≈ 1e-15 relative from it and from LAPACK's :meth:`open_loop_at`."""
        if not self.sampled:
            lo = complex(self.open_loop_at(omega))
            return lo, lo / (1.0 + lo)
        y = omega * self.period
        z = complex(math.cos(y), math.sin(y))
        lo = self.gain * resolvent_position(*self._resolvent_floats, z) / z**self.delay
        return lo, lo / (1.0 + lo)

    def dc_gain(self) -> float:
        """H(z = 1) = C(I − F)⁻¹G [1] of the sampled closed loop (position first)."""
        f, g = self.closed_loop()
        return float(np.linalg.solve(np.eye(f.shape[0]) - f, g[:, 0])[0])

    def radial_error(self, radius: float, feed: float) -> float:
        """r·| |H(jω)| − 1 |, ω = feed/r: |H| − 1 = (|L|² − |1+L|²)/(|1+L|(|L| + |1+L|)),
        whose numerator −1 − 2 Re L does not cancel."""
        lo = self.open_loop_at(feed / radius)
        one = abs(1 + lo)
        return float(radius * abs((-1 - 2 * lo.real) / (one * (abs(lo) + one))))

    def radius_decrease(self, radius: float, feed: float, reference_interval: float) -> float:
        """Sato eq 7, |Δr| = |r − r̄·|H(jω)||, r̄ = r√(sin θ/θ), θ = ω·T_ref (eq 3: the circle
        with the area of the inscribed polygon, a vertex every reference interval), written
        (r − r̄) + r̄·(1 − |H|) with 1 − |H| free of cancellation as in :meth:`radial_error`."""
        omega = feed / radius
        average = average_polygon_radius(radius, omega, reference_interval)
        lo = self.open_loop_at(omega)
        one = abs(1 + lo)
        deficit = (1 + 2 * lo.real) / (one * (abs(lo) + one))  # 1 − |H|
        return float(abs(radius - average + average * deficit))

    # -- what the validation block and the report use -------------------------------------

    def responses(self) -> dict[str, Response]:
        """The unit step and unit ramp responses (dense, exact; the servo has no load input)."""
        t, e, _ = self.step_error(SUBSTEPS)
        one = np.ones_like(t)
        if self.sampled:
            # the reference read at the samples is kT = T·(steps starting at samples 1, 2, …):
            # superpose the step response delayed by whole samples (the grid is aligned)
            step = (one - e).reshape(-1, SUBSTEPS)  # one row per sample
            shifted = np.vstack([np.zeros((1, step.shape[1])), np.cumsum(step, axis=0)[:-1]])
            position = self.period * shifted.ravel()
        else:  # time-invariant: the ramp response is the integral of the step response
            position = np.concatenate([[0.0], np.cumsum((2 - e[1:] - e[:-1]) / 2 * np.diff(t))])
        return {"step": Response("step", t, one, one - e, self.position_unit),
                "ramp": Response("ramp", t, t, position, self.position_unit)}

    def circle_test(self, radius: float, feed: float, substeps: int = CIRCLE_SUBSTEPS) -> CircleTrace:
        """The steady two-axis circle test, simulated in time (both axes at once as the
        complex position x + jy).

        Reference: the circle r·e^{jωt} itself (Koren), or with an interpolator a vertex
        r·e^{jωiT} every reference interval T, the reference moving along each chord and
        read every sampling period (Sato Figs 1–3). A continuous loop follows r·e^{jωt}
        exactly (the exponential input is a state of the augmented system); a sampled loop
        holds the command over each period and the drive is resolved on ``substeps``
        points per period. Simulated until the transient has decayed to SETTLED, then one
        revolution is kept; the deviation is |y| − r against the angle of y.
        """
        omega = feed / radius
        revolution = 2 * math.pi / omega
        if not self.sampled:
            f, g = self.closed_loop()
            m = f.shape[0]
            big = np.zeros((m + 1, m + 1), dtype=complex)
            big[:m, :m], big[:m, m:], big[m, m] = f, g, 1j * omega
            h = revolution / (CIRCLE_SUBSTEPS * 16)
            settle = self._blocks_to_settle(expm(f * h))
            step = expm(big * h)
            state = np.zeros(m + 1, dtype=complex)
            state[m] = radius
            state = np.linalg.matrix_power(step, settle) @ state
            points = np.empty(CIRCLE_SUBSTEPS * 16 + 1, dtype=complex)
            for i in range(points.size):
                points[i] = state[0]
                state = step @ state
            return _trace(radius, feed, points)
        f, g = self.closed_loop()
        a, b, c = self.drive_matrices()
        m, n, period = a.shape[0], f.shape[0], self.period
        settle = self._blocks_to_settle()
        total = settle + math.ceil(revolution / period) + 1
        k = np.arange(total)
        reference = self._circle_reference(radius, omega, k * period)
        states = np.zeros((total, n), dtype=complex)
        for i in range(total - 1):
            states[i + 1] = f @ states[i] + g[:, 0] * reference[i]
        if self.delay == 0:
            held = self.gain * (reference - states[:, :m] @ c[0])
        else:
            held = states[:, n - 1]
        big = np.zeros((m + 1, m + 1))
        big[:m, :m], big[:m, m:] = a, b
        rows = _first_rows(expm(big * period / substeps), substeps)
        keep = slice(total - 1 - math.ceil(revolution / period), total - 1)
        starts = np.column_stack([states[keep, :m], held[keep]])
        points = (starts @ rows.T).ravel()
        return _trace(radius, feed, points)

    def _circle_reference(self, radius: float, omega: float, t: np.ndarray) -> np.ndarray:
        """The reference at times ``t`` [s]: the circle, or the interpolated polygon."""
        if self.reference_interval is None:
            return radius * np.exp(1j * omega * t)
        theta = omega * self.reference_interval
        side = np.floor(t / self.reference_interval + 1e-12)
        fraction = t / self.reference_interval - side
        vertex = radius * np.exp(1j * theta * side)
        return vertex + fraction * vertex * (np.exp(1j * theta) - 1)

    def frequency_metrics(self) -> dict[str, float]:
        """M_peak, bandwidth [rad/s], crossover [rad/s], phase margin [deg] and M_s of the
        continuous loop L = K/(s(1 + sτ)) in closed form, from the second-order closed
        loop T = ω_n²/(s² + 2ζω_n s + ω_n²), ω_n = √(K/τ), ζ = 1/(2√(Kτ)) (Koren eqs 9–10;
        Ogata, Modern Control Engineering, 5th ed., §8-6 for M_r and ω_b):

        * M_peak = 1/(2ζ√(1 − ζ²)) for ζ < 1/√2, else 1 (|T| falls from ω = 0);
        * ω_b = ω_n √(1 − 2ζ² + √(4ζ⁴ − 4ζ² + 2));
        * ω_c from |L| = 1: ω_c² = (√(1 + 4K²τ²) − 1)/(2τ²); PM = 90° − atan(ω_c τ);
        * M_s: |S|² = x(1 + τ²x)/((K − τx)² + x) with x = ω² is largest where
          2τ³x² − 2Kτ²x − K = 0, x = (Kτ + √(K²τ² + 2Kτ))/(2τ²).

        The phase −90° − atan(ωτ) never reaches −180°: there is no gain margin to measure.
        """
        if self.sampled:
            raise NotCovered("closed forms of the continuous loop only")
        return dict(self._frequency_metrics)

    @functools.cached_property
    def _frequency_metrics(self) -> dict[str, float]:
        """:meth:`frequency_metrics`, once per model (its table reads one value a metric)."""
        k, tau = self.gain, self.time_constant
        omega_n, zeta = math.sqrt(k / tau), 1 / (2 * math.sqrt(k * tau))
        m_peak = 1 / (2 * zeta * math.sqrt(1 - zeta**2)) if zeta < math.sqrt(0.5) else 1.0
        bandwidth = omega_n * math.sqrt(1 - 2 * zeta**2 + math.sqrt(4 * zeta**4 - 4 * zeta**2 + 2))
        crossover = math.sqrt((math.sqrt(1 + 4 * (k * tau) ** 2) - 1) / (2 * tau**2))
        x = (k * tau + math.sqrt((k * tau) ** 2 + 2 * k * tau)) / (2 * tau**2)
        m_s = math.sqrt(x * (1 + tau**2 * x) / ((k - tau * x) ** 2 + x))
        return {"m_peak": m_peak, "bandwidth": bandwidth, "crossover_frequency": crossover,
                "phase_margin": 90.0 - math.degrees(math.atan(crossover * tau)),
                "sensitivity_peak": m_s}

    def measurement_tables(self) -> tuple[Phase, ...]:
        """The metrics this loop re-measures (:data:`SERVO_MEASUREMENTS`); on a sampled
        loop the frequency and step-shape ones
        (:data:`feedtune.validate.sampled_frequency.MEASUREMENTS`), on the continuous one
        its closed-form frequency metrics (:data:`REFERENCE_PULSE_FREQUENCY`)."""
        if self.sampled:
            return (Phase({**SERVO_MEASUREMENTS, **sampled_frequency.MEASUREMENTS}),)
        return (Phase({**SERVO_MEASUREMENTS, **REFERENCE_PULSE_FREQUENCY}),)

    def measure(self, result: dict) -> list[dict]:
        """Entries for the step integrals (plain and natural time), ζ, ω_n, C_v, the radial
        error (Koren eq 28), the minimum radius, Sato's average radius and decrease in
        radius (eqs 3, 7) and the circle test, judged by
        :func:`feedtune.validate.tolerances.judge`."""
        return measure_entries(self, self.measurement_tables(), result, self.context())

    def blu_criterion(self, radii) -> np.ndarray:
        """r·| |H(jV_m/r)| − 1 | [m] at each radius r [m]: the radial error of a circle at
        V_m (Koren eqs 30–31 on the loop's own |H|), |H| − 1 without cancellation."""
        radii = np.atleast_1d(np.asarray(radii, dtype=float))
        return _criterion(radii, self.open_loop(self.max_velocity / radii))

    def criterion_at(self, radius: float) -> float:
        """:meth:`blu_criterion` at one radius [m] (brentq's and Brent's ≈ 34 calls a spec),
        its value to the bit: L by :meth:`open_loop_at`, the moduli by numpy's ufunc (its
        SIMD loop rounds otherwise than Python's abs), the real arithmetic in floats (one
        correctly rounded operation each, as numpy's)."""
        lo = self.open_loop_at(self.max_velocity / radius)
        one = float(np.abs(1 + lo))
        return radius * abs((1 + 2 * float(lo.real)) / (one * (float(np.abs(lo)) + one)))

    def min_radius(self, level: float | None = None) -> float:
        """r_min [m]: the smallest r* such that every circle of radius r ≥ r* traversed at
        V_m has a radial error ≤ ``level`` [m] (default BLU/2, Koren eqs 30–32).

        The error need not fall monotonically with r: it can dip below the level and rise
        above it again (where the ω² and ω⁴ terms of eq 28 have opposite signs), so r_min
        is the largest radius where the error crosses the level upwards as r decreases.
        Radii from V_m/C_v (an error of the order of the following error V_m/C_v ≫ BLU)
        up MIN_RADIUS_SPAN decades (more while the largest still fails), RADII_PER_DECADE
        per decade; every local maximum of
        the grid above the largest failing grid point is refined (bounded Brent on ln r),
        so that a failing band narrower than the grid is not missed; brentq then finds the
        crossing above the largest failing radius.
        """
        level = self.blu / 2 if level is None else level
        for extensions in range(MIN_RADIUS_EXTENSIONS + 1):  # a slow loop: further up
            grid, values = self._criterion_scan(extensions)
            if values[-1] <= level:  # until a circle passes
                break
        if values[-1] > level:
            raise NotCovered("no radius in the bracket meets the BLU/2 criterion")
        if values[0] <= level:
            raise NotCovered("even r = V_m/C_v meets the BLU/2 criterion (f_m/C_v too small)")
        worst = float(grid[values > level][-1])
        peaks = np.nonzero((values[1:-1] >= values[:-2]) & (values[1:-1] >= values[2:]))[0] + 1
        for i in peaks:
            if values[i] > level or grid[i + 1] <= worst:
                continue
            where, peak = self._criterion_peak(float(grid[i - 1]), float(grid[i + 1]))
            if peak > level:
                worst = max(worst, where)
        above = grid > worst
        upper = float(grid[above][np.argmax(values[above] <= level)])
        return float(brentq(lambda r: self.criterion_at(r) - level, worst, upper,
                            xtol=1e-15 * worst))

    @functools.lru_cache(maxsize=MIN_RADIUS_EXTENSIONS + 1)
    def _criterion_scan(self, extensions: int) -> tuple[np.ndarray, np.ndarray]:
        """(radii [m], :meth:`blu_criterion` [m]) of the minimum-radius scan, extended
        ``extensions`` times by MIN_RADIUS_SPAN decades. Kept: :meth:`min_radius_judged`
        asks for three levels on the same scan."""
        if extensions == 0:
            low = self.max_velocity * self.ramp_following_error()  # V_m/C_v
            grid = np.geomspace(low, low * 10.0**MIN_RADIUS_SPAN,
                                RADII_PER_DECADE * MIN_RADIUS_SPAN + 1)
            return grid, self._scan_criterion(grid)
        grid, values = self._criterion_scan(extensions - 1)
        more = grid[1:] * (grid[-1] / grid[0])
        return np.concatenate([grid, more]), np.concatenate([values, self._scan_criterion(more)])

    def _scan_criterion(self, radii: np.ndarray) -> np.ndarray:
        """:meth:`blu_criterion` on the scan's radii [m], L by :meth:`_grid_open_loop`
        (0.5 of 0.6 ms a scan were the 1601 LAPACK solves). The scan only brackets: r_min
        and the peaks are refined on :meth:`criterion_at`."""
        return _criterion(radii, self._grid_open_loop(self.max_velocity / radii))

    @functools.lru_cache(maxsize=64)
    def _criterion_peak(self, lower: float, upper: float) -> tuple[float, float]:
        """(radius [m], :meth:`blu_criterion` [m]) of the criterion's largest value between
        the radii ``lower`` and ``upper`` [m] (bounded Brent on ln r), for any level."""
        res = minimize_scalar(lambda u: -self.criterion_at(math.exp(u)),
                              bounds=(math.log(lower), math.log(upper)),
                              method="bounded", options={"xatol": 1e-12})
        return math.exp(float(res.x)), float(-res.fun)

    def min_radius_judged(self, reported: float) -> tuple[float, tuple[float, str]]:
        """(r_min [m], (allowed gap [m], its label)): a reported radius agrees when it lies
        between the minimum radii for BLU/2 + BLU/1000 and BLU/2 − BLU/1000, i.e. when the
        criterion would have to move by more than BLU/1000 to give it; this also accepts
        either side of a dip that just touches BLU/2, where r_min jumps."""
        value = self.min_radius()
        band = CRITERION_BAND * self.blu
        if reported >= value:
            edge, label = self.min_radius(self.blu / 2 - band), "r_min(BLU/2 − BLU/1000) − r_min"
        else:
            edge, label = self.min_radius(self.blu / 2 + band), "r_min − r_min(BLU/2 + BLU/1000)"
        return value, (abs(edge - value), label)

    def circle_statistics(self, radius: float, feed: float) -> dict[str, float]:
        """circle_mean_deviation (time mean of |y| − r), circularity (max − min) and
        circle_roughness (the largest max − min within a window of one reference interval)
        of :meth:`circle_test` [m]."""
        # 0.2 s of imports, for Sato's interpolated circles only: not every worker's
        from scipy.ndimage import maximum_filter1d, minimum_filter1d

        trace = self.circle_test(radius, feed)
        d = trace.deviation
        stats = {"circle_mean_deviation": float(np.mean(d)), "circularity": float(np.ptp(d))}
        window = CIRCLE_SUBSTEPS * self.reference_interval / self.period
        size = min(d.size, int(round(window)) + 1)
        stats["circle_roughness"] = float(np.max(maximum_filter1d(d, size, mode="wrap")
                                                 - minimum_filter1d(d, size, mode="wrap")))
        return stats


class PadeServoModel(ContinuousModel):
    """Sato's continuous stand-in for the sampled loop (eqs 4–5): the dead time
    L = (d + ½)·T as its (1,1) Padé approximant, open loop K(1 − Ls/2)/((1 + Ls/2)s(1 + sτ)),
    1/s without τ; a state-space block (controllable canonical form) closed by unity
    feedback. The model's own numbers are re-measured (the tuner's arithmetic on it); what
    the sampled loop really does is the ``exact`` model's (docs/sato.md)."""

    position_unit = "m"

    def __init__(self, gain: float, time_constant: float | None, period: float, delay: int,
                 reference_interval: float | None, blu: float | None = None):
        half = (delay + 0.5) * period / 2
        den = np.polymul(np.polymul([half, 1.0], [time_constant or 0.0, 1.0]), [1.0, 0.0])
        block = siso([-gain * half, gain], den)
        closed_a = block.a - block.b @ block.c
        closed_b = np.column_stack([block.b[:, 0], np.zeros(block.order)])
        super().__init__((closed_a, closed_b, block.c[0]), (block.a, block.b, block.c[0]),
                         has_load=False)
        self.gain, self.reference_interval, self.blu = gain, reference_interval, blu

    def context(self) -> Context:
        """The continuous loop's time scale, and the BLU [m] where the spec gives one."""
        return replace(super().context(), blu=self.blu)

    def circle_test(self, radius, feed):
        raise NotCovered("the Padé model is a continuous stand-in for the sampled loop: no "
                         "circle test (tune with model 'exact' for it)")

    def measurement_tables(self) -> tuple[Phase, ...]:
        """The continuous loop's tables, then ζ and ω_n of a second-order loop and Sato's
        average radius and decrease in radius with this loop's |H|
        (:data:`PADE_MEASUREMENTS`)."""
        return super().measurement_tables() + (Phase(PADE_MEASUREMENTS),)


def _criterion(radii: np.ndarray, open_loop: np.ndarray) -> np.ndarray:
    """r·| |H| − 1 | [m] at radii r [m] from L there: |H| − 1 = (|L|² − |1 + L|²)/(|1 + L|
    (|L| + |1 + L|)), whose numerator −1 − 2 Re L does not cancel."""
    one = np.abs(1 + open_loop)
    return radii * np.abs((1 + 2 * open_loop.real) / (one * (np.abs(open_loop) + one)))


def _solve_resolvent(matrix: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """x of matrix·x = rhs (complex, n × n and n × 1) by LAPACK's ``zgesv`` (LU with partial
    pivoting), the routine ``np.linalg.solve`` calls, through ``scipy.linalg.lapack``:
    ≈ 1 µs where ``np.linalg.solve``'s checks, type promotion and error state add ≈ 5 µs
    around the same call (the minimum radius's ≈ 34 one-ω calls a batch spec). The same
    bits as ``np.linalg.solve`` (tests/unit/test_validator_one_frequency.py), and its
    error for a singular matrix."""
    _, _, x, info = zgesv(matrix, rhs)
    if info > 0:
        raise np.linalg.LinAlgError("Singular matrix")
    return x


def resolvent_position(phi: list, gamma: list, z):
    """C(zI − Φ)⁻¹Γ [m per (m/s)] of the drive's one or two states, C = [1, 0] (the
    position first), by Cramer's rule: Γ₀/(z − Φ₀₀), or ((z − Φ₁₁)Γ₀ + Φ₀₁Γ₁)/
    ((z − Φ₀₀)(z − Φ₁₁) − Φ₀₁Φ₁₀); Φ rows and Γ as floats, z a complex number or an
    array of them (numpy's arithmetic then, Python's for one)."""
    if len(gamma) == 1:
        return gamma[0] / (z - phi[0][0])
    if len(gamma) != 2:
        raise ValueError(f"Cramer's rule here is written for 1 or 2 drive states, not {len(gamma)}")
    second = z - phi[1][1]
    return ((second * gamma[0] + phi[0][1] * gamma[1])
            / ((z - phi[0][0]) * second - phi[0][1] * phi[1][0]))


def _pair(s: np.ndarray) -> tuple[float, float]:
    """(ζ, ω_n [rad/s]) of s-plane poles s1, s2: ω_n = √(s1 s2), ζ = −(s1 + s2)/(2ω_n)."""
    wn = math.sqrt(abs((s[0] * s[1]).real))
    return float(-(s[0] + s[1]).real / (2 * wn)), wn


def sampled_pole_pair(poles: np.ndarray, period: float) -> tuple[float, float]:
    """(ζ, ω_n [rad/s]) of a second-order sampled loop's z-poles through s = ln(z)/T
    (Koren eqs 17–19), T = ``period`` [s]. A negative real z-pole rings at the Nyquist
    frequency: s = ln|z| ± jπ/T of the most negative one."""
    p = np.asarray(poles)
    if p.size != 2:
        raise NotCovered(f"ζ and ω_n need a second-order loop (order {p.size})")
    if np.all(np.abs(p.imag) < 1e-14 * np.abs(p)) and np.min(p.real) < 0:
        z = float(np.min(p.real))
        s = np.array([complex(math.log(abs(z)), math.pi),
                      complex(math.log(abs(z)), -math.pi)]) / period
    else:
        s = np.log(p.astype(complex)) / period
    return _pair(s)


def average_polygon_radius(radius: float, omega: float, reference_interval: float) -> float:
    """r̄ [m]: N = 2π/θ triangles of area r² sin(θ/2)cos(θ/2) = r² sin θ/2 have the area
    of a circle of radius r√(sin θ/θ) (Sato eqs 1–3), θ = ω·T_ref [rad]."""
    theta = omega * reference_interval
    return radius * math.sqrt(math.sin(theta) / theta)


def _trace(radius: float, feed: float, points: np.ndarray) -> CircleTrace:
    """The CircleTrace of path ``points`` (complex [m]) over one revolution."""
    return CircleTrace(radius, feed, np.angle(points), np.abs(points) - radius)


def _first_rows(matrix: np.ndarray, count: int) -> np.ndarray:
    """The first rows of I, M, M², ..., M^(count−1), stacked (count, n)."""
    return _orbit(matrix.T, np.eye(matrix.shape[0])[0], count)


def _orbit(matrix: np.ndarray, start: np.ndarray, count: int) -> np.ndarray:
    """start, M·start, M²·start, ..., M^(count−1)·start as rows (count, n), by doubling:
    the rows so far times (M^k)ᵀ give the next k, so log2(count) matrix products replace
    count matrix-vector products in Python (≈ 1 ms a step response; the same numbers up
    to rounding, ≈ 1e-16 relative per doubling)."""
    rows = np.asarray(start)[None, :]
    power = matrix
    while rows.shape[0] < count:
        rows = np.vstack([rows, rows @ power.T])
        power = power @ power
    return rows[:count]


def _free_position(x0, v0, u, tau: float, s):
    """x̃(s) [m] of the drive 1/(s(1 + sτ)) from position x0 and speed v0 under the held
    command u [m/s], s [s] into the sample: x0 + u·s + (v0 − u)·τ(1 − e^{−s/τ})."""
    return x0 + u * s - (v0 - u) * tau * np.expm1(-s / tau)


def _free_zero(x0, v0, u, tau: float, lower, upper) -> np.ndarray:
    """The zero [s] of :func:`_free_position` in [lower, upper], where it is monotone and
    changes sign: Newton's method from the end where x̃·x̃'' > 0 (x̃'' has the sign of
    u − v0), whose iterates then approach the zero from one side without overshoot."""
    at_lower = _free_position(x0, v0, u, tau, lower) * (u - v0) > 0
    s = np.where(at_lower, lower, upper)
    converged = 4 * np.finfo(float).eps * upper
    for _ in range(NEWTON_STEPS):
        speed = u + (v0 - u) * np.exp(-s / tau)
        step = _free_position(x0, v0, u, tau, s) / speed
        s = np.clip(s - step, lower, upper)
        if np.all(np.abs(step) <= converged):
            break
    return s


def _free_integrals(x0, v0, u, tau: float | None, s) -> tuple[np.ndarray, np.ndarray]:
    """(∫₀ˢ e dσ [m·s], ∫₀ˢ σ·e dσ [m·s²]) of the error e = −x̃ of the free drive
    (:func:`_free_position`; without τ, x̃ = x0 + u·σ), in closed form with
    g = 1 − e^{−s/τ}: ∫g = s − τg, ∫σg = s²/2 + τs − τ(s + τ)g."""
    first = x0 * s + u * s * s / 2
    moment = x0 * s * s / 2 + u * s**3 / 3
    if tau is not None:
        g = -np.expm1(-s / tau)
        first = first + (v0 - u) * tau * (s - tau * g)
        moment = moment + (v0 - u) * tau * (s * s / 2 + tau * s - tau * (s + tau) * g)
    return -first, -moment


# -- the tables: metric → measurement ---------------------------------------------------


def _equivalent_pair(model: ServoModel, cache: dict) -> tuple[float, float] | None:
    """(ζ, ω_n) of a second-order loop, None otherwise; once per result."""
    if "pair" not in cache:
        try:
            cache["pair"] = model.equivalent_pair()
        except NotCovered:
            cache["pair"] = None
    return cache["pair"]


def _step_integral(model: ServoModel, options: dict, cache: dict, name: str) -> float:
    """IAE, ISE or ITAE after a unit step; in natural time ω_n·t multiplies by ω_n^p."""
    if "integrals" not in cache:
        cache["integrals"] = model.error_integrals()
    value = cache["integrals"][name]
    if options.get("time", "absolute") == "natural":
        pair = _equivalent_pair(model, cache)
        if pair is None:
            raise NotCovered("natural time needs a second-order loop's ω_n")
        value *= pair[1] ** {"iae": 1, "ise": 1, "itae": 2}[name]
    return value


def _pair_value(index: int):
    def measure(model: ServoModel, options: dict, reported, cache: dict) -> float:
        pair = _equivalent_pair(model, cache)
        if pair is None:
            raise NotCovered("ζ and ω_n need a second-order loop")
        return pair[index]
    return measure


def _sato_circle(model: ServoModel, options: dict, name: str) -> float:
    """Sato's average radius (eq 3) or decrease in radius (eq 7) at the tuned interval."""
    omega, interval = options["feed"] / options["radius"], model.reference_interval
    if name == "average_radius":
        return average_polygon_radius(options["radius"], omega, interval)
    return model.radius_decrease(options["radius"], options["feed"], interval)


def _circle_statistic(model: ServoModel, options: dict, cache: dict, name: str) -> float:
    """One statistic of the simulated circle test, the test run once per circle."""
    key = ("circle", options["radius"], options["feed"])
    if key not in cache:
        cache[key] = model.circle_statistics(options["radius"], options["feed"])
    return cache[key][name]


def _min_radius(model: ServoModel, options: dict, reported: float, cache: dict):
    """(r_min, its judging scale) for the reported radius (a radius beyond the scan is
    NotCovered: that entry only is left out)."""
    return model.min_radius_judged(reported)


def _step_input(model, options: dict) -> bool:
    return options.get("input", "step") == "step"


def _has_interpolator(model, options: dict) -> bool:
    return model.reference_interval is not None


def _has_koren_scales(model, options: dict) -> bool:
    return model.blu is not None and model.max_velocity is not None


#: ServoModel (continuous or sampled): metric → measurement
SERVO_MEASUREMENTS: dict[str, Measurement] = {
    **{name: Measurement(lambda m, o, r, c, name=name: _step_integral(m, o, c, name), _step_input)
       for name in ("iae", "ise", "itae")},
    "damping_ratio": Measurement(_pair_value(0)),
    "natural_frequency": Measurement(_pair_value(1)),
    "velocity_constant": Measurement(lambda m, o, r, c: 1.0 / m.ramp_following_error()),
    "radial_error": Measurement(lambda m, o, r, c: m.radial_error(o["radius"], o["feed"]),
                                lambda m, o: "radius" in o and "feed" in o),
    **{name: Measurement(lambda m, o, r, c, name=name: _sato_circle(m, o, name), _has_interpolator)
       for name in ("radius_decrease", "average_radius")},
    "min_radius": Measurement(_min_radius, _has_koren_scales),
    **{name: Measurement(lambda m, o, r, c, name=name: _circle_statistic(m, o, c, name),
                         _has_interpolator)
       for name in ("circle_mean_deviation", "circularity", "circle_roughness")},
}


def _no_phase_crossover(model: ServoModel, options: dict, reported, cache: dict) -> float:
    """+∞: the phase −90° − atan(ωτ) of K/(s(1 + sτ)) never reaches −180° (Koren 1979
    eq 5), so no gain makes the loop unstable (python-control's gm = inf)."""
    return math.inf


#: the continuous (reference-pulse) ServoModel's frequency metrics, in closed form
#: (:meth:`ServoModel.frequency_metrics`): metric → measurement
REFERENCE_PULSE_FREQUENCY: dict[str, Measurement] = {
    **{name: Measurement(lambda m, o, r, c, name=name: m.frequency_metrics()[name])
       for name in ("m_peak", "bandwidth", "crossover_frequency", "phase_margin",
                    "sensitivity_peak")},
    "gain_margin": Measurement(_no_phase_crossover),
}


def _pade_circle(model: PadeServoModel, options: dict, name: str) -> float:
    """Sato eq 3 (average radius) and eq 7 with the Padé loop's |H|."""
    radius, omega = options["radius"], options["feed"] / options["radius"]
    average = average_polygon_radius(radius, omega, model.reference_interval)
    h = abs(model.frequency_response(omega)[1][0])
    return average if name == "average_radius" else abs(radius - average * h)


#: PadeServoModel, beyond the continuous loop's table: metric → measurement
PADE_MEASUREMENTS: dict[str, Measurement] = {
    **PAIR_MEASUREMENTS,
    **{name: Measurement(lambda m, o, r, c, name=name: _pade_circle(m, o, name),
                         lambda m, o: bool(m.reference_interval))
       for name in ("radius_decrease", "average_radius")},
}
