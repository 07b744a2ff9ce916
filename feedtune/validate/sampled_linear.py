"""The ``linear`` plant's sampled implementation for the validator, from the spec's numbers.

The digital loop of ``implementation: sampled`` (:mod:`feedtune.plants.linear`) written
again with scipy, never from :mod:`feedtune.loops.sampled_lti`:

* the drive (:func:`feedtune.validate.linear.drive_block`; a velocity output integrated to
  the position) behind a zero-order hold, discretised by ``scipy.signal.cont2discrete``
  (``zoh``); its input dead time θ = d·T + θ_f split into whole samples d, held commands of
  the loop, and a fraction 0 ≤ θ_f < T, over which the plant still sees the previous
  command (the modified z-transform: x(k+1) = Φx(k) + Γ₀u(k−c−d) + Γ₁u(k−c−d−1),
  Γ₀ the hold over T − θ_f, Γ₁ = e^{A(T−θ_f)}·(the hold over θ_f); Franklin, Powell &
  Workman ch. 4.3.4);
* the controllers (:func:`feedtune.validate.linear.controller_block`) discretised by
  ``cont2discrete`` as state space, ``bilinear`` (Tustin) or ``backward_diff``
  (backward Euler, the generalised bilinear transform with α = 1);
* the difference equations at sample k, with c the computation delay: without a velocity
  loop e = r − y, u = C_p(z)e; with one v_ref = K_p(r − y) + k_ff(r(k) − r(k−1))/T,
  e = v_ref − v (v = ẏ at the sample, C A x), u = C_v(z)e; u(k) enters a buffer of c + d
  (+ 1 with a fraction) held commands.

A discrete drive (``model.period``: its coefficients or matrices in z) takes the place of
the held drive: its own A, B, C (realised and balanced as a drive in s is) with Φ = A,
Γ₀ = B, Γ₁ = 0, T = ``model.period`` and d its whole samples of dead time; it has no motion
between samples, so no step integrals (the loop reports none) and a step response at the
samples.

They are assembled into one recursion s(k+1) = F s(k) + G r(k), whose eigenvalues are the
poles; H(e^{jωT}) = C(zI − F)⁻¹G; the open loop L is the same recursion with the
controller's position input cut (L = −position per injected position, the inner
velocity loop closed); the step response is exact between samples (``expm`` of the
drive with the held command, the fraction's switch a grid point). The metrics are those
of :mod:`feedtune.validate.sampled_frequency` and the software servo's step integrals,
ζ/ω_n, C_v and radial error (:data:`feedtune.validate.software_servo.SERVO_MEASUREMENTS`).

References
----------
G. F. Franklin, J. D. Powell, M. L. Workman, *Digital Control of Dynamic Systems*, 3rd
ed., 1998, §4.3.4 (ZOH with a fractional delay), §6.3 (Tustin, backward rule).
Y. Koren, "Design of computer control for manufacturing systems", 1979, Fig 4 (the
sampled-data position loop), eqs 28, 37 (radial error).
"""

from __future__ import annotations

import functools
import math

import numpy as np
from scipy.linalg import expm, matrix_balance

from feedtune.validate import sampled_frequency
from feedtune.validate.continuous import Block
from feedtune.validate.integrals import error_integrals
from feedtune.validate.linear import controller_block, drive_block
from feedtune.validate.measurements import Measurement, Phase, measure_entries
from feedtune.validate.model import CircleTrace, NotCovered, Response
from feedtune.validate.software_servo import SERVO_MEASUREMENTS, sampled_pole_pair
from feedtune.validate.tolerances import Context

#: cont2discrete's method for each spec ``discretisation``
METHODS = {"tustin": "bilinear", "backward_euler": "backward_diff"}
#: θ/T within this (relative) of a whole number is that number of samples, no fraction
WHOLE = 1e-9
#: the step response runs until the free response has decayed to this fraction
SETTLED = 1e-13
#: at most this many samples are simulated (a nearly undamped loop is refused)
MAX_SAMPLES = 200_000
#: sub-steps per sample: at least SUBSTEPS, and 100 per fastest drive time constant (at most
#: MAX_SUBSTEPS); the step integrals' trapezoid then errs by ~(hω)²/12 ≤ 1e-5
SUBSTEPS, MAX_SUBSTEPS = 256, 4096
#: at most this many points of the dense step response (160 MB per array of floats)
MAX_POINTS = 20_000_000
#: an open-loop pole within this of z = 1 is an integrator of the loop (its type)
INTEGRATOR = 1e-9


def _hold(a: np.ndarray, b: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray]:
    """(e^{A·step}, ∫₀^step e^{As}ds·B): the ZOH of (A, B) over ``step`` [s] by scipy."""
    n = a.shape[0]
    if step == 0:
        return np.eye(n), np.zeros((n, 1))
    from scipy.signal import cont2discrete  # 0.5 s of imports: only here
    phi, gamma, *_ = cont2discrete((a, b, np.zeros((1, n)), np.zeros((1, 1))), step, "zoh")
    return phi, gamma


def _balanced(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> Block:
    """(A, B, C) rescaled by a diagonal similarity (``scipy.linalg.matrix_balance`` of
    [[A, B], [C, 0]], the input and output kept): a transfer function's companion form can
    hold entries from 1 to 1e9 (the README's two-mass drive), and its sampled loop's
    zI − F is then too ill-conditioned for the frequency responses to keep 1e-7."""
    n = a.shape[0]
    _, (scaling, _) = matrix_balance(np.block([[a, b], [c, np.zeros((1, 1))]]),
                                     permute=False, separate=True)
    states = scaling[:n] / scaling[n]
    return Block(a * states[None, :] / states[:, None], b / states[:, None],
                 c * states[None, :], np.zeros((1, 1)))


class SampledLinearModel:
    """Validator model of ``linear`` with ``implementation: sampled`` at tuned numbers."""

    sampled = True

    def __init__(self, plant: dict, tuned: dict):
        model = plant["model"]
        #: a discrete drive (``model.period``): its own matrices in z, no intersample motion
        self.discrete = model.get("period") is not None
        self.period = period = float(model["period"] if self.discrete
                                     else tuned["sampling_period"])
        self.position_unit = plant["output_unit"].removesuffix("/s")
        self.cascade = plant.get("velocity_controller", "none") != "none"
        self.feedforward = float(plant.get("velocity_feedforward", 0.0)) if self.cascade else 0.0
        self.delay = int(plant.get("computation_delay", 0))
        drive = drive_block(model)  # in z for a discrete drive: the same realisation
        if np.any(drive.d):
            raise NotCovered("a drive with direct feedthrough (D ≠ 0) is not modelled")
        a, b, c = drive.a, drive.b, drive.c
        if self.discrete:  # a position output and a position controller (LinearParams)
            self.drive = _balanced(a, b, c)
            self.whole, self.fraction = self._discrete_dead_time(plant), 0.0
            self.phi, self.gamma_late = self.drive.a, self.drive.b
            self.gamma_early = np.zeros_like(self.drive.b)
        else:
            self._sample_drive(plant, a, b, c)
        method = METHODS[plant.get("discretisation", "tustin")]
        loop = "velocity" if self.cascade else "position"
        law = controller_block(loop, plant, tuned)
        if self.cascade:
            position = controller_block("position", plant, tuned)
            if position.order:
                raise NotCovered("a sampled cascade's position controller is a gain")
            self.position_gain = float(position.d[0, 0])
        if law.order:
            from scipy.signal import cont2discrete  # 0.5 s of imports: only here
            ad, bd, cd, dd, _ = cont2discrete((law.a, law.b, law.c, law.d), period, method)
        else:
            ad, bd, cd, dd = law.a, law.b, law.c, law.d
        self.controller = Block(ad, bd, cd, dd)
        self.held = self.delay + self.whole + (1 if self.fraction > 0 else 0)
        self._layout()

    def _discrete_dead_time(self, plant: dict) -> int:
        """A discrete drive's dead time in whole samples: ``dead_time_samples``, or
        ``dead_time`` [s] (a whole multiple of the period, checked by the spec) over T."""
        samples = int(plant.get("dead_time_samples") or 0)
        return samples or round(float(plant.get("dead_time", 0.0)) / self.period)

    def _sample_drive(self, plant: dict, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> None:
        """A drive in s behind the ZOH: Φ, Γ₀, Γ₁ with the dead time's whole samples and
        fraction (the modified z-transform)."""
        period = self.period
        if plant["output_unit"] not in ("m", "rad"):  # a velocity output: x = ∫y
            n = a.shape[0]
            a = np.block([[a, np.zeros((n, 1))], [c, np.zeros((1, 1))]])
            b, c = np.vstack([b, [[0.0]]]), np.eye(1, n + 1, n)
        self.drive = _balanced(a, b, c)
        a, b = self.drive.a, self.drive.b
        # dead time: whole samples d, and the fraction θ_f
        theta = float(plant.get("dead_time", 0.0))
        whole = math.floor(theta / period + WHOLE)
        fraction = theta - whole * period
        if fraction <= WHOLE * period:
            fraction = 0.0
        self.whole, self.fraction = whole, fraction
        self.phi, self.gamma = _hold(a, b, period)
        late_phi, self.gamma_late = _hold(a, b, period - fraction)
        early_phi, early_gamma = _hold(a, b, fraction)
        self.gamma_early = late_phi @ early_gamma  # applied over the first θ_f of a period
        self.early = (early_phi, early_gamma)

    @classmethod
    def from_result(cls, plant: dict, tuned: dict, stability: dict | None = None):
        return cls(plant, tuned)

    # -- the recursion -------------------------------------------------------------------

    def _layout(self) -> None:
        """State s = [drive x (n), controller x_c (n_c), r(k−1) (with feed-forward),
        u(k−1) … u(k−L)]: slices by name."""
        sizes = [("x", self.drive.order), ("xc", self.controller.order),
                 ("rprev", 1 if self.feedforward else 0), ("held", self.held)]
        self.slices, start = {}, 0
        for name, size in sizes:
            self.slices[name] = slice(start, start + size)
            start += size
        self.order = start

    def _recursion(self, cut: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(F, G, u): s(k+1) = F s(k) + G [r(k), w(k)], u(k) = u·[s; r; w].

        w is the position the controller reads when the loop is ``cut`` there (else it
        reads C x and the column of w is zero)."""
        n, total = self.order, self.order + 2
        sl = self.slices
        x = np.zeros((1, total))
        x[0, sl["x"]] = self.drive.c[0]
        if cut:
            measured = np.zeros((1, total))
            measured[0, n + 1] = 1.0
        else:
            measured = x
        reference = np.eye(1, total, n)
        if self.cascade:  # v_ref − v
            velocity = np.zeros((1, total))
            velocity[0, sl["x"]] = self.drive.c[0] @ self.drive.a
            error = self.position_gain * (reference - measured) - velocity
            if self.feedforward:
                rate = self.feedforward / self.period
                previous = np.zeros((1, total))
                previous[0, sl["rprev"]] = 1.0
                error = error + rate * (reference - previous)
        else:
            error = reference - measured
        ctrl = self.controller
        own = np.zeros((ctrl.order, total))
        own[:, sl["xc"]] = ctrl.a
        command = ctrl.d[0, 0] * error
        command[0, sl["xc"]] += ctrl.c[0]
        nxt = np.zeros((n, total))
        nxt[sl["xc"]] = own + ctrl.b @ error
        if self.feedforward:
            nxt[sl["rprev"]] = reference
        held = sl["held"]
        if self.held:
            nxt[held.start] = command[0]
            for i in range(1, self.held):
                nxt[held.start + i, held.start + i - 1] = 1.0

        def past(lag: int) -> np.ndarray:  # u(k − lag) as a row
            if lag == 0:
                return command
            row = np.zeros((1, total))
            row[0, held.start + lag - 1] = 1.0
            return row

        lag = self.delay + self.whole
        drive = np.zeros((self.drive.order, total))
        drive[:, sl["x"]] = self.phi  # e^{AT}, whether or not the input switches at θ_f
        drive += self.gamma_late @ past(lag)
        if self.fraction:
            drive += self.gamma_early @ past(lag + 1)
        nxt[sl["x"]] = drive
        return nxt[:, :n], nxt[:, n:], command[0]

    @functools.cached_property
    def _closed(self):
        return self._recursion(cut=False)

    @functools.cached_property
    def _open(self):
        return self._recursion(cut=True)

    def closed_loop(self) -> tuple[np.ndarray, np.ndarray]:
        """(F, G): s(k+1) = F s(k) + G r(k)."""
        f, g, _ = self._closed
        return f, g[:, [0]]

    def position_row(self) -> np.ndarray:
        row = np.zeros(self.order)
        row[self.slices["x"]] = self.drive.c[0]
        return row

    # -- the Model protocol ------------------------------------------------------------

    def poles(self) -> np.ndarray:
        """z-plane poles [1]: eigenvalues of F."""
        return np.linalg.eigvals(self.closed_loop()[0])

    def stable(self) -> bool:
        return bool(np.max(np.abs(self.poles())) < 1)

    def context(self) -> Context:
        """The slowest time constant 1/min|s| [s] of the poles s = ln z / T (z ≠ 0)."""
        p = self.poles().astype(complex)
        speeds = np.abs(np.log(p[np.abs(p) > 1e-12]) / self.period)
        speeds = speeds[speeds > 0]
        return Context(time=1.0 / float(np.min(speeds)) if speeds.size else None,
                       position_unit=self.position_unit)

    def equivalent_pair(self) -> tuple[float, float]:
        """(ζ, ω_n [rad/s]) of a second-order loop's z-poles through s = ln(z)/T."""
        return sampled_pole_pair(self.poles(), self.period)

    def _resolvent(self, omega, f: np.ndarray, g: np.ndarray) -> np.ndarray:
        """C(zI − F)⁻¹g at z = e^{jωT}, ω [rad/s]."""
        omega = np.atleast_1d(np.asarray(omega, dtype=float))
        z = np.exp(1j * omega * self.period)
        n = f.shape[0]
        solved = np.linalg.solve(z[:, None, None] * np.eye(n) - f,
                                 np.broadcast_to(g.reshape(n, 1), (z.size, n, 1)))[:, :, 0]
        return solved @ self.position_row()

    def open_loop(self, omega) -> np.ndarray:
        """L(e^{jωT}) = −(position per position the controller reads), the loop cut there."""
        f, g, _ = self._open
        return -self._resolvent(omega, f, g[:, 1])

    def complementary(self, omega) -> np.ndarray:
        """H(e^{jωT}) = position/reference at the samples, the feed-forward included."""
        f, g = self.closed_loop()
        return self._resolvent(omega, f, g[:, 0])

    def frequency_response_at(self, omega: float) -> tuple[complex, complex]:
        """(L, H) at one ω [rad/s] (the frequency metrics' refinements)."""
        return complex(self.open_loop(omega)[0]), complex(self.complementary(omega)[0])

    def dc_gain(self) -> float:
        """H(1) = C(I − F)⁻¹G [1]."""
        f, g = self.closed_loop()
        return float(self.position_row() @ np.linalg.solve(np.eye(self.order) - f, g[:, 0]))

    def frequency_response(self, omega) -> tuple[np.ndarray, np.ndarray]:
        """(L, H) at ``omega`` [rad/s] ≤ π/T."""
        return self.open_loop(omega), self.complementary(omega)

    def loop_type(self) -> int:
        """Open-loop poles at z = 1 (integrators of drive and controller in the loop)."""
        return int(np.sum(np.abs(np.linalg.eigvals(self._open[0]) - 1) < INTEGRATOR))

    def ramp_following_error(self) -> float:
        """Steady error kT − y(kT) at the samples after a unit ramp r(k) = kT [m]: the
        solution s(k) = p0 + k·p1 of the recursion (p1 = (I − F)⁻¹G T, p0 = −(I − F)⁻¹p1)
        has the error −C p0 when C p1 = T (a loop that follows the ramp's rate)."""
        f, g = self.closed_loop()
        eye = np.eye(self.order)
        p1 = np.linalg.solve(eye - f, g[:, 0] * self.period)
        p0 = np.linalg.solve(eye - f, -p1)
        return float(-self.position_row() @ p0)

    def radial_error(self, radius: float, feed: float) -> float:
        """r·| |H(e^{jωT})| − 1 | [m], ω = feed/r: the circle at the samples, |H| − 1
        written (|H|² − 1)/(|H| + 1) with |H|² − 1 = |S|² − 2 Re S, S = 1 − H."""
        s = 1.0 - self.complementary(feed / radius)[0]
        h = abs(1.0 - s)
        return float(radius * abs((abs(s) ** 2 - 2 * s.real) / (h + 1.0)))

    # -- the step response between samples -----------------------------------------------

    def _substeps(self) -> int:
        fastest = float(np.max(np.abs(np.linalg.eigvals(self.drive.a)), initial=0.0))
        return int(min(MAX_SUBSTEPS, max(SUBSTEPS, math.ceil(100 * self.period * fastest))))

    def step_samples(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(states s(k), commands u(k), the state after the last) at the samples k = 0 …
        after a unit step, until the free response has decayed to SETTLED."""
        f, g, command = self._closed
        radius = float(np.max(np.abs(np.linalg.eigvals(f))))
        if radius >= 1:
            raise NotCovered("unstable loop: no step response settles")
        samples = (math.ceil(math.log(SETTLED) / math.log(radius)) + 10) if radius > 0 else 10
        if samples > MAX_SAMPLES:
            raise NotCovered(f"the step response needs {samples} samples (limit {MAX_SAMPLES})")
        states = np.empty((samples, self.order))
        state = np.zeros(self.order)
        for k in range(samples):
            states[k] = state
            state = f @ state + g[:, 0]
        inputs = np.column_stack([states, np.ones(samples), np.zeros(samples)])
        return states, inputs @ command, state

    def step_error(self) -> tuple[np.ndarray, np.ndarray]:
        """(t [s], e = 1 − y(t)) after a unit step, exact at every point of a grid with
        ``_substeps()`` points per sample (and the fraction's switch θ_f)."""
        if self.discrete:  # the loop refuses the step integrals of such a drive too
            raise NotCovered("a discrete drive model has no response between samples")
        states, now, state = self.step_samples()
        samples = states.shape[0]
        sl = self.slices

        def past(lag: int) -> np.ndarray:
            return now if lag == 0 else states[:, sl["held"].start + lag - 1]

        lag = self.delay + self.whole
        x = states[:, sl["x"]]
        a, b, c = self.drive.a, self.drive.b, self.drive.c[0]
        m = a.shape[0]
        big = np.zeros((m + 1, m + 1))
        big[:m, :m], big[:m, m:] = a, b
        count = self._substeps()
        if samples * count > MAX_POINTS:
            raise NotCovered(f"the step response needs {samples} samples × {count} points "
                             f"(limit {MAX_POINTS} points)")
        pieces, offset = [], 0.0
        if self.fraction:  # the first θ_f of each period: the previous command
            early = max(1, math.ceil(count * self.fraction / self.period))
            count = max(1, count - early)
            pieces.append(self._segment(big, c, np.column_stack([x, past(lag + 1)]),
                                        self.fraction, early))
            phi_f, gamma_f = self.early
            x = x @ phi_f.T + np.outer(past(lag + 1), gamma_f[:, 0])
            offset = self.fraction
        times, values = self._segment(big, c, np.column_stack([x, past(lag)]),
                                      self.period - self.fraction, count)
        pieces.append((times + offset, values))
        t = np.concatenate([p[0] for p in pieces])
        y = np.concatenate([p[1] for p in pieces], axis=1)  # (samples, points per sample)
        grid = (np.arange(samples)[:, None] * self.period + t[None, :]).ravel()
        grid = np.append(grid, samples * self.period)
        position = np.append(y.ravel(), self.position_row() @ state)
        return grid, 1.0 - position

    @staticmethod
    def _segment(big, c, starts, length: float, count: int):
        """(offsets [s], positions): C·x at ``count`` equal steps from 0 (inclusive) to
        ``length`` (exclusive) of ẋ = A x + B u, u held, from each row of ``starts``."""
        m = c.size
        step = expm(big * length / count)
        rows = np.empty((count, m + 1))
        rows[0] = np.concatenate([c, [0.0]])
        for i in range(1, count):
            rows[i] = rows[i - 1] @ step
        return np.arange(count) * length / count, starts @ rows.T

    def error_integrals(self) -> dict[str, float]:
        """IAE [m·s], ISE [m²·s], ITAE [m·s²] after a unit step on the exact dense grid
        (:func:`feedtune.validate.integrals.error_integrals`)."""
        return error_integrals(*self.step_error())

    def responses(self) -> dict[str, Response]:
        """The unit step response (the report's; no load input): at the samples only for a
        discrete drive."""
        if self.discrete:
            states, _, _ = self.step_samples()
            t = np.arange(states.shape[0]) * self.period
            one = np.ones_like(t)
            return {"step": Response("step", t, one, states @ self.position_row(),
                                     self.position_unit)}
        t, e = self.step_error()
        one = np.ones_like(t)
        return {"step": Response("step", t, one, one - e, self.position_unit)}

    def circle_test(self, radius: float, feed: float) -> CircleTrace:
        raise NotCovered("the sampled user-defined loop has no circle-test simulation")

    # -- the tables ----------------------------------------------------------------------

    def measurement_tables(self) -> tuple[Phase, ...]:
        """:data:`SAMPLED_LINEAR_MEASUREMENTS`."""
        return (Phase(SAMPLED_LINEAR_MEASUREMENTS),)

    def measure(self, result: dict) -> list[dict]:
        return measure_entries(self, self.measurement_tables(), result, self.context())


#: the sampled ``linear`` loop: metric → measurement (the step integrals, ζ/ω_n, C_v and
#: the radial error as the software servo measures them; the frequency metrics of
#: :mod:`feedtune.validate.sampled_frequency`, the gain margin on the phase net of the loop's
#: integrators)
SAMPLED_LINEAR_MEASUREMENTS: dict[str, Measurement] = {
    **{name: SERVO_MEASUREMENTS[name]
       for name in ("iae", "ise", "itae", "damping_ratio", "natural_frequency",
                    "velocity_constant", "radial_error")},
    **{name: sampled_frequency.MEASUREMENTS[name]
       for name in ("m_peak", "sensitivity_peak", "bandwidth", "crossover_frequency",
                    "phase_margin")},
    "gain_margin": Measurement(lambda m, o, r, c: sampled_frequency.gain_margin(m, m.loop_type())),
}
