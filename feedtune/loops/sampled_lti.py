"""General sampled-data loop: any SISO LTI drive behind a zero-order hold, any discrete controller.

A continuous plant ẋ = A x + B u(t − θ), position y = C x (numeric state space, input dead
time θ ≥ 0), or a discrete plant (A_d, B_d, C_d) with its own period, is sampled every T; a
discrete controller in state space (:class:`DiscreteController`, its matrices expressions
of T and the tunables) reads the reference, the sampled position and, for a cascade, the
sampled velocity; its output is held by a ZOH ``delay`` whole samples later. T may be a
tunable: the plant's transition e^{AT} and ∫₀ᵀe^{As}ds·B are CasADi expressions of T
(:func:`feedtune.loops.sampled_plants.expm_function`), exact to rounding and differentiable.
Plants are in :mod:`feedtune.loops.sampled_plants`, controllers in
:mod:`feedtune.loops.sampled_controllers`.

:class:`SampledLTILoop` offers the Loop interface of :class:`feedtune.loops.loop.SampledLoop`
(state matrices, characteristic polynomial, Schur conditions, C_v, frequency and error
responses at z = e^{jωT} up to Nyquist, exact step-error integrals between samples), so
the metrics and the tuner take it unchanged. The integrals are in
:mod:`feedtune.loops.sampled_lti_integrals`.

References
----------
Koren 1979, sampled-data loop (Fig 4, eqs 14–19); Franklin, Powell & Workman, *Digital
Control of Dynamic Systems*, ch. 4 (ZOH models with a fractional input delay).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

from feedtune.lazy import ca, np
from feedtune.loops import linalg
from feedtune.loops.loop import (SETTLE_FRACTION, Drive, Interpolator, StepIntegrals,
                                 _SampledLoopBase)
from feedtune.loops.protocols import Capability
from feedtune.loops.sampled_controllers import DiscreteController
from feedtune.loops.sampled_plants import (ContinuousPlant, DiscretePlant, SampledModelError,
                                           expm_function)


@dataclass(frozen=True, eq=False)
class SampledLTILoop(_SampledLoopBase):
    """Sampled-data loop of an LTI plant, a ZOH and a discrete controller, exact between samples.

    State at sample k: [plant x (n), controller x_c, u(k−1), …, u(k−L)], with L the held
    commands still in flight: the computation delay c plus the dead time's whole samples
    d, plus one when a fractional part θ_f remains (the plant then sees u(k−c−d−1) for θ_f
    and u(k−c−d) for T − θ_f of each period; Franklin, Powell & Workman, ch. 4).

    Attributes
    ----------
    plant : ContinuousPlant or DiscretePlant
    controller : DiscreteController
    period : expression
        Sampling period T [s]; a DiscretePlant's own period.
    period_box : (float, float)
        (T_min, T_max) [s]: the box of T (equal for a fixed T).
    delay : int
        Computation delay in whole samples.
    horizon : float
        Time [s] after which every loop in the tuning box has settled; the step integrals
        are summed over ``horizon / T_min`` samples, then in closed form.
    drive : Drive
    interpolator : Interpolator or None
    frequency_band : tuple or None
        (low, high) [rad/s] numbers: ``low`` below every corner of the loop, ``high`` above
        the Nyquist frequency π/T of every period in the box (as
        :attr:`feedtune.loops.loop.SampledLoop.frequency_band`); None: no frequency metric.
    """

    plant: ContinuousPlant | DiscretePlant
    controller: DiscreteController
    period: object
    period_box: tuple = (1e-3, 1e-3)
    delay: int = 0
    horizon: float = 1.0
    drive: Drive = field(default_factory=Drive)
    interpolator: Interpolator | None = None
    frequency_band: tuple | None = None
    discrete = True
    capabilities = frozenset({Capability.LINEAR, Capability.FREQUENCY_RESPONSE,
                              Capability.OPEN_LOOP, Capability.VELOCITY_CONSTANT,
                              Capability.EXACT_STEP_ERROR, Capability.SAMPLE_HORIZON})

    def __post_init__(self):
        if int(self.delay) != self.delay or self.delay < 0:
            raise SampledModelError(f"/controller/delay: {self.delay}, must be a whole number "
                                    "of samples ≥ 0")
        low, high = self.period_box
        if not (0 < low <= high):
            raise SampledModelError(f"/tunables/sampling_period: box {self.period_box} s, "
                                    "need 0 < min ≤ max")
        if self.plant.discrete:
            if not (low == high and abs(low - self.plant.period) <= 1e-12 * self.plant.period):
                raise SampledModelError(
                    f"/tunables/sampling_period: a discrete plant runs at its own period "
                    f"{self.plant.period:g} s; the sampling period must be fixed to it")

    @property
    def period_min(self) -> float:
        return self.period_box[0]

    # -- discretisation -----------------------------------------------------------------

    @cached_property
    def _split(self):
        """(whole dead-time samples d, fractional dead time θ_f [s] or 0)."""
        if self.plant.discrete:
            return self.plant.dead_time_samples, 0
        return self.plant.split_dead_time(self.period, self.period_box)

    @property
    def has_fraction(self) -> bool:
        return not (isinstance(self._split[1], (int, float)) and self._split[1] == 0)

    @cached_property
    def _hold_exponential(self) -> ca.Function:
        """h ↦ e^{M h} − I of M = [[A, B], [0, 0]]: [[e^{Ah} − I, ∫₀ʰe^{As}ds B], [0, 0]],
        h ≤ T_max."""
        a, b = self.plant.a, self.plant.b
        n = self.plant.order
        m = np.zeros((n + 1, n + 1))
        m[:n, :n], m[:n, n:] = a, b
        return expm_function(m, self.period_box[1], minus_identity=True)

    def _hold(self, h):
        """(e^{Ah} − I, ∫₀ʰe^{As}ds·B) over h [s] (ZOH)."""
        n = self.plant.order
        e = self._hold_exponential(h)
        return e[:n, :n], e[:n, n]

    @cached_property
    def _plant_difference(self):
        """(Φ − I, Γ₀, Γ₁): x(k+1) − x(k) = (Φ − I)x(k) + Γ₀u(k−c−d) + Γ₁u(k−c−d−1), Φ − I
        without the cancellation of forming Φ (its entries are 1 − O(|λ|T) for a short T)."""
        if self.plant.discrete:  # given as Φ: nothing to recover
            n = self.plant.order
            return ca.DM(self.plant.a) - ca.DM.eye(n), ca.DM(self.plant.b), ca.DM.zeros(n, 1)
        fraction = self._split[1]
        if not self.has_fraction:
            phi, gamma = self._hold(self.period)
            return phi, gamma, ca.DM.zeros(self.plant.order, 1)
        late, late_gamma = self._hold(self.period - fraction)
        early, early_gamma = self._hold(fraction)
        # (I + F_l)(I + F_e) − I = F_l + F_e + F_l F_e
        return (late + early + ca.mtimes(late, early), late_gamma,
                early_gamma + ca.mtimes(late, early_gamma))

    @cached_property
    def plant_transition(self):
        """(Φ, Γ₀, Γ₁): x(k+1) = Φx(k) + Γ₀u(k−c−d) + Γ₁u(k−c−d−1)."""
        if self.plant.discrete:
            n = self.plant.order
            return ca.DM(self.plant.a), ca.DM(self.plant.b), ca.DM.zeros(n, 1)
        eye = ca.DM.eye(self.plant.order)
        difference, gamma0, gamma1 = self._plant_difference
        if not self.has_fraction:
            return eye + difference, gamma0, gamma1
        fraction = self._split[1]
        late, late_gamma = self._hold(self.period - fraction)
        early, early_gamma = self._hold(fraction)
        late_phi = eye + late
        return (ca.mtimes(late_phi, eye + early), late_gamma, ca.mtimes(late_phi, early_gamma))

    @property
    def held_samples(self) -> int:
        """L: past commands kept as states."""
        return self.delay + self._split[0] + (1 if self.has_fraction else 0)

    @property
    def order(self) -> int:
        return self.plant.order + self.controller.order + self.held_samples

    @cached_property
    def _kind(self):
        """``ca.DM`` for a loop of numbers (its period and its controller's matrices
        numbers), ``ca.MX`` otherwise: the type its matrices are assembled in. A loop of
        numbers (the validator's, a robust search's, a batch's reports, the contract
        tests' grids) thus computes Φ, Γ and its polynomial once, on numbers, instead of
        building MX graphs of constants that every reader evaluated again."""
        c = self.controller
        symbols = any(isinstance(v, (ca.MX, ca.SX)) for v in (self.period, c.a, c.b, c.c, c.d))
        return ca.MX if symbols else ca.DM

    @cached_property
    def _measurement(self):
        """(C, C A or 0): the rows that give the controller's sampled position and velocity,
        w = [r, C x, C A x]."""
        c = ca.DM(self.plant.c)
        velocity = (ca.DM(self.plant.velocity_row) if self.controller.uses_velocity
                    else ca.DM.zeros(1, self.plant.order))
        return c, velocity

    def command(self, lag: int, cut: bool = False):
        """(K, k): u(k − lag) = K·state + k·r, the command ``lag`` samples old; with ``cut``
        the controller's position input is not the plant's (the loop opened there, see
        :meth:`open_loop_response`) and K leaves it out."""
        n, nc, total = self.plant.order, self.controller.order, self.order
        kind = self._kind
        if lag == 0:
            c, velocity = self._measurement
            dc = kind(self.controller.d)
            kx = dc[0, 2] * velocity + (0 if cut else dc[0, 1] * c)
            row = ca.horzcat(kx, kind(self.controller.c), kind.zeros(1, self.held_samples))
            return row, dc[0, 0]
        row = ca.DM.zeros(1, total)
        row[0, n + nc + lag - 1] = 1
        return kind(row), 0

    def _assemble(self, cut: bool):
        """(Φ, Γ_r, Γ_w): state(k+1) = Φ state(k) + Γ_r r(k) + Γ_w w(k), w the controller's
        position input: the sampled position (Γ_w = 0, folded into Φ) unless ``cut``."""
        n, nc, held = self.plant.order, self.controller.order, self.held_samples
        total = self.order
        kind = self._kind
        phi_p, gamma0, gamma1 = self.plant_transition
        dc = kind(self.controller.d)
        lag = self.delay + self._split[0]
        k0, r0 = self.command(lag, cut)
        rows = [ca.horzcat(phi_p, kind.zeros(n, total - n)) + ca.mtimes(gamma0, k0)]
        inputs = [gamma0 * r0]
        cut_inputs = [gamma0 * dc[0, 1] if cut and lag == 0 else kind.zeros(n, 1)]
        if self.has_fraction:
            k1, r1 = self.command(lag + 1, cut)
            rows[0] = rows[0] + ca.mtimes(gamma1, k1)
            inputs[0] = inputs[0] + gamma1 * r1
        if nc:
            c, velocity = self._measurement
            bc = kind(self.controller.b)
            x_part = ca.mtimes(bc[:, 2], velocity) + (0 if cut else ca.mtimes(bc[:, 1], c))
            rows.append(ca.horzcat(x_part, kind(self.controller.a), kind.zeros(nc, held)))
            inputs.append(bc[:, 0])
            cut_inputs.append(bc[:, 1] if cut else kind.zeros(nc, 1))
        if held:
            k_now, r_now = self.command(0, cut)
            shift = ca.horzcat(ca.DM.zeros(held - 1, n + nc), ca.DM.eye(held - 1),
                               ca.DM.zeros(held - 1, 1)) if held > 1 else ca.DM.zeros(0, total)
            rows += [k_now, kind(shift)]
            inputs += [r_now, kind.zeros(held - 1, 1)]
            cut_inputs += [dc[0, 1] if cut else kind(0), kind.zeros(held - 1, 1)]
        return (ca.vertcat(*rows), ca.vertcat(*[kind(i) for i in inputs]),
                ca.vertcat(*[kind(i) for i in cut_inputs]))

    @cached_property
    def _matrices(self):
        return self._assemble(cut=False)[:2]

    @cached_property
    def _difference_form(self):
        """(B, g, k): Φ − I = B + g·k, k the row of the command u(k) = k·state + … (the
        controller's output), g the column it enters the state by, B the rest.

        The controller's gains (a backward-Euler PI's K(1 + T/T_i), 1e5 at T/T_i = 700)
        are in k alone, and the plant's transition in B as e^{AT} − I: what the
        characteristic polynomial is computed from (:attr:`shifted_polynomial`)."""
        n, nc, held = self.plant.order, self.controller.order, self.held_samples
        total = self.order
        kind = self._kind
        difference, gamma0, gamma1 = self._plant_difference
        lag = self.delay + self._split[0]
        plant = ca.horzcat(difference, kind.zeros(n, total - n))
        if lag:
            plant = plant + ca.mtimes(gamma0, self.command(lag)[0])
        if self.has_fraction:
            plant = plant + ca.mtimes(gamma1, self.command(lag + 1)[0])
        rows, column = [plant], [gamma0 if lag == 0 else ca.DM.zeros(n, 1)]
        if nc:
            c, velocity = self._measurement
            bc = kind(self.controller.b)
            x_part = ca.mtimes(bc[:, 2], velocity) + ca.mtimes(bc[:, 1], c)
            rows.append(ca.horzcat(x_part, kind(self.controller.a) - ca.DM.eye(nc),
                                   kind.zeros(nc, held)))
            column.append(ca.DM.zeros(nc, 1))
        if held:  # h₁(k+1) − h₁(k) = u(k) − h₁(k); h_i(k+1) − h_i(k) = h_{i−1}(k) − h_i(k)
            shift = np.zeros((held, total))
            for i in range(held):
                shift[i, n + nc + i] = -1.0
                if i:
                    shift[i, n + nc + i - 1] = 1.0
            rows.append(kind(ca.DM(shift)))
            column.append(ca.DM(np.eye(held, 1)))
        return ca.vertcat(*rows), ca.vertcat(*[kind(c) for c in column]), self.command(0)[0]

    @cached_property
    def shifted_polynomial(self) -> list:
        """q(x) = det(xI − (Φ − I)) [1], x = z − 1, highest power first: the closed loop's
        characteristic polynomial about z = 1.

        det(xI − B − g k) = det(xI − B) − k·adj(xI − B)·g, both from one Faddeev–LeVerrier
        recursion on B (adj(xI − B) = Σ_j x^{n−j} M_j). Poles clustered near z = 1 (a
        short T: |z| = 0.9999998 at T = 10 µs on a 10 ms drive) make p(1) = q(0) a product
        of small numbers that the monomial coefficients of p(z), all O(1), hold no digit
        of (it came out exactly 0 at stable points); here it is −det(B + g k) itself. And a
        large controller gain enters linearly, not through products of Φ's entries.
        """
        b, g, k = self._difference_form
        n = self.order
        eye = ca.DM.eye(n)
        m = self._kind(eye)
        out = [self._kind(1)]
        for j in range(1, n + 1):
            feedback = ca.mtimes(k, ca.mtimes(m, g))
            bm = ca.mtimes(b, m)
            c = -ca.trace(bm) / j
            out.append(c - feedback)
            m = bm + c * eye
        return out

    @cached_property
    def characteristic_polynomial(self) -> list:
        """Monic det(zI − Φ) [1], highest power first: :attr:`shifted_polynomial` at
        x = z − 1 (a Taylor shift)."""
        return linalg.taylor_shift(self.shifted_polynomial, -1.0)

    def stability_conditions(self) -> list:
        """Expressions all positive iff every pole has |z| < 1: the Hurwitz (Liénard–Chipart)
        conditions of q(x) mapped by z = (1 + w)/(1 − w), i.e. x = 2w/(1 − w)."""
        return linalg.hurwitz_conditions(_half_plane(self.shifted_polynomial))

    def settling_conditions(self) -> list:
        """As :meth:`feedtune.loops.loop._SampledLoopBase.settling_conditions` (every pole inside
        |z| < r, r = SETTLE_FRACTION^(1/N)), written on q: the poles z/r are x' = (x + 1 −
        r)/r, so the test is of q(r x' − (1 − r)), 1 − r taken by expm1 (r is 1 − 1e-5 for
        N = 10⁶ samples)."""
        if "step_error_integrals" not in self.__dict__:
            return []
        shrink = -math.expm1(math.log(SETTLE_FRACTION) / self.horizon_samples)  # 1 − r
        moved = linalg.taylor_shift(self.shifted_polynomial, -shrink)
        radius = 1 - shrink
        scaled = [c * radius ** (-j) for j, c in enumerate(moved)]  # monic, roots ÷ r
        return linalg.hurwitz_conditions(_half_plane(scaled))

    @cached_property
    def _open_matrices(self):
        """(Φ_o, Γ_w) of the loop opened at the controller's position input."""
        phi, _, gamma_w = self._assemble(cut=True)
        return phi, gamma_w

    @property
    def open_loop_matrices(self):
        """(Φ_o, Γ_w): state(k+1) = Φ_o state(k) + Γ_w w(k), the loop opened at the
        controller's sampled position input w (:meth:`open_loop_response`)."""
        return self._open_matrices

    @property
    def position_row(self):
        return ca.horzcat(ca.DM(self.plant.c), ca.DM.zeros(1, self.order - self.plant.order))

    # -- responses ----------------------------------------------------------------------

    @cached_property
    def _state_difference(self):
        """Φ − I = B + g·k (:attr:`_difference_form`), without forming Φ first; a loop of
        numbers holds it as numbers (DM), so that its Hessenberg form and its solves are
        computed once, on numbers, instead of as graphs that every response of the loop
        evaluates again (the same operations)."""
        b, g, k = self._difference_form
        return _numbers_if_fixed(b + ca.mtimes(g, k))

    def _settled(self, rhs):
        """(I − Φ)⁻¹·rhs: the steady state per constant input."""
        return linalg.pivoted_solve(-self._state_difference, _numbers_if_fixed(rhs))

    @cached_property
    def _hessenberg(self):
        """(H, Q): Φ − I = Q·H·Qᵀ with H upper Hessenberg (:func:`linalg.hessenberg`), once
        per loop: every frequency's resolvent is then an O(n²) solve."""
        return linalg.hessenberg(self._state_difference)

    def _resolvent(self, omega, rhs):
        """C(zI − Φ)⁻¹·rhs at z = e^{jωT} of the closed loop, ω [rad/s] a number or a row of
        them (one expression for the row), from Φ − I = Q H Qᵀ: zI − Φ = Q((z − 1)I − H)Qᵀ,
        Re(z − 1) = −2 sin²(ωT/2), solved by :func:`linalg.hessenberg_resolvent`.

        Measured (benchmarks/README.md, the 7-state sampled loop's bandwidth under M_peak):
        the dense 2n × 2n real block solve per frequency could not take a row of ω, so each
        frequency row was a mapped call that rebuilt Φ, and the expanded NLP held 227 of them
        (28.7 s of build)."""
        h, q = self._hessenberg
        wt = omega * self.period
        return linalg.hessenberg_resolvent(h, ca.mtimes(q.T, rhs),
                                           ca.mtimes(self.position_row, q),
                                           -2 * ca.sin(wt / 2) ** 2, ca.sin(wt))

    def open_loop_response(self, omega):
        """Re and Im of L(e^{jωT}) [1], ω [rad/s] ≤ π/T: the loop opened at the controller's
        sampled position input, L = −C(zI − Φ_o)⁻¹Γ_w (the position a unit input there
        brings back, sign of the negative feedback removed). Hold, computation delay and
        dead time included; an inner velocity loop stays closed, as in Bhatia's outer loop
        (Ch. IV, Fig 18); periodic in ω with period 2π/T."""
        phi, gamma_w = (ca.MX(m) for m in self._open_matrices)  # the QR below is MX's
        n = self.order
        wt = omega * self.period
        # the QR of linalg.solve, not the pivoted solve of the closed loop's responses:
        # with it the bundled sampled example's phase-margin tuning took 62 IPOPT
        # iterations instead of 30 (same optimum to 1e-13), and L is not where the QR lost
        # digits (L agrees with the validator to 4e-8 on that example, and symbolic with
        # numeric to 1e-9 over the plant contract's grid)
        re, im = linalg.complex_solve(ca.cos(wt) * ca.DM.eye(n) - phi,
                                      ca.sin(wt) * ca.DM.eye(n), gamma_w)
        c = self.position_row
        return -ca.mtimes(c, re), -ca.mtimes(c, im)

    def sensitivity_response(self, omega):
        """Re and Im of S = 1/(1 + L) at z = e^{jωT} [1]: the feedback's sensitivity, which
        differs from the error per reference (:meth:`error_response`) with a feed-forward.

        The measured position w = y + d of an output disturbance d is S·d; with the loop
        closed, S(z) = 1 + C(zI − Φ)⁻¹Γ_w, and S(1) = 0 for a type-1 loop (the only ones
        the plants build), so S(z) = −(z − 1)·C(zI − Φ)⁻¹(I − Φ)⁻¹Γ_w: no cancellation at
        low ω, and no pole on the unit circle (L has one at z = 1)."""
        _, gamma_w = self._open_matrices
        re, im = self._resolvent(omega, self._settled(gamma_w))
        wt = omega * self.period
        d_re, d_im = -2 * ca.sin(wt / 2) ** 2, ca.sin(wt)
        return -(d_re * re - d_im * im), -(d_re * im + d_im * re)

    def dc_gain(self):
        """H(z = 1) = C(I − Φ)⁻¹Γ [1]: 1 for a loop that follows a constant reference, kept
        as an expression for the normalisation |H/H(1)|."""
        return ca.mtimes(self.position_row, self._settled(self.input_matrix))

    def frequency_response(self, omega):
        """Re and Im of position/reference at the samples, z = e^{jωT}, ω [rad/s] ≤ π/T."""
        return self._resolvent(omega, self.input_matrix)

    def error_response(self, omega):
        """Re and Im of S = 1 − H at z = e^{jωT}: (z − 1)·C(zI − Φ)⁻¹(I − Φ)⁻¹Γ, exact at
        low ω for a loop that follows a constant reference (H(1) = 1)."""
        re, im = self._resolvent(omega, self._settled(self.input_matrix))
        wt = omega * self.period
        d_re, d_im = -2 * ca.sin(wt / 2) ** 2, ca.sin(wt)
        return d_re * re - d_im * im, d_re * im + d_im * re

    @property
    def nyquist_frequency(self):
        """π/T [rad/s]: the frequency responses are defined up to here."""
        return ca.pi / self.period

    @property
    def velocity_constant(self):
        """C_v = 1/e_ss of a unit ramp r(k) = kT [1/s]: e_ss = T·C(I − Φ)⁻²Γ for a type-1
        loop (H(1) = 1), from E(z) = (1 − H)·Tz/(z − 1)²; Koren eq 5 in the sampled case."""
        twice = self._settled(self._settled(self.input_matrix))
        return 1 / (self.period * ca.mtimes(self.position_row, twice))

    # -- step-error integrals -----------------------------------------------------------

    @property
    def has_exact_step_error(self) -> bool:
        """A continuous plant: its intersample error is integrated exactly."""
        return not self.plant.discrete

    @cached_property
    def step_error_integrals(self) -> StepIntegrals:
        """IAE [m·s], ISE [m²·s], ITAE [m·s²] after a unit position step, intersample
        included (:func:`feedtune.loops.sampled_lti_integrals.step_integral`)."""
        if not self.has_exact_step_error:
            raise NotImplementedError("a discrete plant model has no intersample response")
        from feedtune.loops.sampled_lti_integrals import step_integral

        radius = self._numeric_spectral_radius
        if radius is not None and radius >= 1:
            return StepIntegrals(lambda name: math.inf)  # unstable: never settles
        samples = self.horizon_samples
        return StepIntegrals(lambda name: step_integral(self, name, samples,
                                                        numeric=radius is not None))

    def segments(self):
        """The held inputs inside one period: [(length [s], K, k)], u = K·state + k·r on a
        segment of that length, in time order."""
        lag = self.delay + self._split[0]
        late = self.command(lag)
        if not self.has_fraction:
            return [(self.period, *late)]
        fraction = self._split[1]
        return [(fraction, *self.command(lag + 1)), (self.period - fraction, *late)]


def _numbers_if_fixed(value):
    """``value`` as a DM when it holds no symbol (an expression of numbers, evaluated
    once), else ``value`` itself."""
    if isinstance(value, (ca.SX, ca.MX)) and not ca.symvar(value):
        return ca.evalf(value)
    return value


def _half_plane(shifted: list) -> list:
    """(1 − w)ⁿ q(2w/(1 − w)) of q(x), x = z − 1, highest power first: |z| < 1 exactly
    when Re w < 0 (z = (1 + w)/(1 − w)); the coefficient q_j of x^{n−j} contributes
    q_j (2w)^{n−j} (1 − w)^j."""
    n = len(shifted) - 1
    result = [0] * (n + 1)
    for j, coefficient in enumerate(shifted):
        term = [coefficient * 2 ** (n - j)] + [0] * (n - j)  # (2w)^{n−j}
        for _ in range(j):
            term = linalg.poly_mul(term, [-1, 1])
        for i, t in enumerate(term):
            result[i] = result[i] + t
    return result
