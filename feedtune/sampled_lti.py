"""General sampled-data loop: any SISO LTI drive behind a zero-order hold, any discrete controller.

A continuous plant ẋ = A x + B u(t − θ), position y = C x (numeric state space, input dead
time θ ≥ 0), or a discrete plant (A_d, B_d, C_d) with its own period, is sampled every T; a
discrete controller in state space (:class:`DiscreteController`, its matrices expressions
of T and the tunables) reads the reference, the sampled position and, for a cascade, the
sampled velocity; its output is held by a ZOH ``delay`` whole samples later. T may be a
tunable: the plant's transition e^{AT} and ∫₀ᵀe^{As}ds·B are CasADi expressions of T
(:func:`feedtune.sampled_plants.expm_function`), exact to rounding and differentiable.
Plants are in :mod:`feedtune.sampled_plants`, controllers in
:mod:`feedtune.sampled_controllers`.

:class:`SampledLTILoop` offers the Loop interface of :class:`feedtune.loop.SampledLoop`
(state matrices, characteristic polynomial, Schur conditions, C_v, frequency and error
responses at z = e^{jωT} up to Nyquist, exact step-error integrals between samples), so
the metrics and the tuner take it unchanged. The integrals are in
:mod:`feedtune.sampled_lti_integrals`.

References
----------
Koren 1979, sampled-data loop (Fig 4, eqs 14–19); Franklin, Powell & Workman, *Digital
Control of Dynamic Systems*, ch. 4 (ZOH models with a fractional input delay).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

from feedtune import linalg
from feedtune.lazy import ca, np
from feedtune.loop import Drive, Interpolator, StepIntegrals, _SampledLoopBase
from feedtune.protocols import Capability
from feedtune.sampled_controllers import DiscreteController
from feedtune.sampled_plants import (ContinuousPlant, DiscretePlant, SampledModelError,
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
        :attr:`feedtune.loop.SampledLoop.frequency_band`); None: no frequency metric.
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
        """h ↦ e^{M h} of M = [[A, B], [0, 0]]: [[e^{Ah}, ∫₀ʰe^{As}ds B], [0, 1]], h ≤ T_max."""
        a, b = self.plant.a, self.plant.b
        n = self.plant.order
        m = np.zeros((n + 1, n + 1))
        m[:n, :n], m[:n, n:] = a, b
        return expm_function(m, self.period_box[1])

    def _hold(self, h):
        """(e^{Ah}, ∫₀ʰe^{As}ds·B) over h [s] (ZOH)."""
        n = self.plant.order
        e = self._hold_exponential(h)
        return e[:n, :n], e[:n, n]

    @cached_property
    def plant_transition(self):
        """(Φ, Γ₀, Γ₁): x(k+1) = Φx(k) + Γ₀u(k−c−d) + Γ₁u(k−c−d−1)."""
        if self.plant.discrete:
            n = self.plant.order
            return ca.DM(self.plant.a), ca.DM(self.plant.b), ca.DM.zeros(n, 1)
        fraction = self._split[1]
        if not self.has_fraction:
            phi, gamma = self._hold(self.period)
            return phi, gamma, ca.DM.zeros(self.plant.order, 1)
        late_phi, late_gamma = self._hold(self.period - fraction)
        early_phi, early_gamma = self._hold(fraction)
        return (ca.mtimes(late_phi, early_phi), late_gamma, ca.mtimes(late_phi, early_gamma))

    @property
    def held_samples(self) -> int:
        """L: past commands kept as states."""
        return self.delay + self._split[0] + (1 if self.has_fraction else 0)

    @property
    def order(self) -> int:
        return self.plant.order + self.controller.order + self.held_samples

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
        if lag == 0:
            c, velocity = self._measurement
            dc = ca.MX(self.controller.d)
            kx = dc[0, 2] * velocity + (0 if cut else dc[0, 1] * c)
            row = ca.horzcat(kx, ca.MX(self.controller.c), ca.MX.zeros(1, self.held_samples))
            return row, dc[0, 0]
        row = ca.DM.zeros(1, total)
        row[0, n + nc + lag - 1] = 1
        return ca.MX(row), 0

    def _assemble(self, cut: bool):
        """(Φ, Γ_r, Γ_w): state(k+1) = Φ state(k) + Γ_r r(k) + Γ_w w(k), w the controller's
        position input: the sampled position (Γ_w = 0, folded into Φ) unless ``cut``."""
        n, nc, held = self.plant.order, self.controller.order, self.held_samples
        total = self.order
        phi_p, gamma0, gamma1 = self.plant_transition
        dc = ca.MX(self.controller.d)
        lag = self.delay + self._split[0]
        k0, r0 = self.command(lag, cut)
        rows = [ca.horzcat(phi_p, ca.MX.zeros(n, total - n)) + ca.mtimes(gamma0, k0)]
        inputs = [gamma0 * r0]
        cut_inputs = [gamma0 * dc[0, 1] if cut and lag == 0 else ca.MX.zeros(n, 1)]
        if self.has_fraction:
            k1, r1 = self.command(lag + 1, cut)
            rows[0] = rows[0] + ca.mtimes(gamma1, k1)
            inputs[0] = inputs[0] + gamma1 * r1
        if nc:
            c, velocity = self._measurement
            bc = ca.MX(self.controller.b)
            x_part = ca.mtimes(bc[:, 2], velocity) + (0 if cut else ca.mtimes(bc[:, 1], c))
            rows.append(ca.horzcat(x_part, ca.MX(self.controller.a), ca.MX.zeros(nc, held)))
            inputs.append(bc[:, 0])
            cut_inputs.append(bc[:, 1] if cut else ca.MX.zeros(nc, 1))
        if held:
            k_now, r_now = self.command(0, cut)
            shift = ca.horzcat(ca.DM.zeros(held - 1, n + nc), ca.DM.eye(held - 1),
                               ca.DM.zeros(held - 1, 1)) if held > 1 else ca.DM.zeros(0, total)
            rows += [k_now, ca.MX(shift)]
            inputs += [r_now, ca.MX.zeros(held - 1, 1)]
            cut_inputs += [dc[0, 1] if cut else ca.MX(0), ca.MX.zeros(held - 1, 1)]
        return (ca.vertcat(*rows), ca.vertcat(*[ca.MX(i) for i in inputs]),
                ca.vertcat(*[ca.MX(i) for i in cut_inputs]))

    @cached_property
    def _matrices(self):
        return self._assemble(cut=False)[:2]

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
    def state_matrix(self):
        """Φ_cl: state(k+1) = Φ_cl state(k) + Γ_cl r(k)."""
        return self._matrices[0]

    @property
    def input_matrix(self):
        return self._matrices[1]

    @property
    def position_row(self):
        return ca.horzcat(ca.DM(self.plant.c), ca.DM.zeros(1, self.order - self.plant.order))

    # -- responses ----------------------------------------------------------------------

    def _resolvent(self, omega, rhs, matrix=None):
        """C(zI − Φ)⁻¹·rhs at z = e^{jωT} (Φ the closed loop's, or ``matrix``)."""
        n = self.order
        wt = omega * self.period
        matrix = self.state_matrix if matrix is None else matrix
        re, im = linalg.complex_solve(ca.cos(wt) * ca.DM.eye(n) - matrix,
                                      ca.sin(wt) * ca.DM.eye(n), rhs)
        c = self.position_row
        return ca.mtimes(c, re), ca.mtimes(c, im)

    def open_loop_response(self, omega):
        """Re and Im of L(e^{jωT}) [1], ω [rad/s] ≤ π/T: the loop opened at the controller's
        sampled position input, L = −C(zI − Φ_o)⁻¹Γ_w (the position a unit input there
        brings back, sign of the negative feedback removed). Hold, computation delay and
        dead time included; an inner velocity loop stays closed, as in Bhatia's outer loop
        (Ch. IV, Fig 18); periodic in ω with period 2π/T."""
        phi, gamma_w = self._open_matrices
        re, im = self._resolvent(omega, gamma_w, phi)
        return -re, -im

    def sensitivity_response(self, omega):
        """Re and Im of S = 1/(1 + L) at z = e^{jωT} [1]: the feedback's sensitivity, which
        differs from the error per reference (:meth:`error_response`) with a feed-forward.

        The measured position w = y + d of an output disturbance d is S·d; with the loop
        closed, S(z) = 1 + C(zI − Φ)⁻¹Γ_w, and S(1) = 0 for a type-1 loop (the only ones
        the plants build), so S(z) = −(z − 1)·C(zI − Φ)⁻¹(I − Φ)⁻¹Γ_w: no cancellation at
        low ω, and no pole on the unit circle (L has one at z = 1)."""
        _, gamma_w = self._open_matrices
        settled = linalg.solve(ca.DM.eye(self.order) - self.state_matrix, gamma_w)
        re, im = self._resolvent(omega, settled)
        wt = omega * self.period
        d_re, d_im = -2 * ca.sin(wt / 2) ** 2, ca.sin(wt)
        return -(d_re * re - d_im * im), -(d_re * im + d_im * re)

    def dc_gain(self):
        """H(z = 1) = C(I − Φ)⁻¹Γ [1]: 1 for a loop that follows a constant reference, kept
        as an expression for the normalisation |H/H(1)|."""
        settled = linalg.solve(ca.DM.eye(self.order) - self.state_matrix, self.input_matrix)
        return ca.mtimes(self.position_row, settled)

    def frequency_response(self, omega):
        """Re and Im of position/reference at the samples, z = e^{jωT}, ω [rad/s] ≤ π/T."""
        return self._resolvent(omega, self.input_matrix)

    def error_response(self, omega):
        """Re and Im of S = 1 − H at z = e^{jωT}: (z − 1)·C(zI − Φ)⁻¹(I − Φ)⁻¹Γ, exact at
        low ω for a loop that follows a constant reference (H(1) = 1)."""
        settled = linalg.solve(ca.DM.eye(self.order) - self.state_matrix, self.input_matrix)
        re, im = self._resolvent(omega, settled)
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
        eye = ca.DM.eye(self.order)
        once = linalg.solve(eye - self.state_matrix, self.input_matrix)
        twice = linalg.solve(eye - self.state_matrix, once)
        return 1 / (self.period * ca.mtimes(self.position_row, twice))

    # -- step-error integrals -----------------------------------------------------------

    @property
    def has_exact_step_error(self) -> bool:
        """A continuous plant: its intersample error is integrated exactly."""
        return not self.plant.discrete

    @cached_property
    def step_error_integrals(self) -> StepIntegrals:
        """IAE [m·s], ISE [m²·s], ITAE [m·s²] after a unit position step, intersample
        included (:func:`feedtune.sampled_lti_integrals.step_integral`)."""
        if not self.has_exact_step_error:
            raise NotImplementedError("a discrete plant model has no intersample response")
        from feedtune.sampled_lti_integrals import step_integral

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
