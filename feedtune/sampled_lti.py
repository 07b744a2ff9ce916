"""General sampled-data loop: any SISO LTI drive behind a zero-order hold, any discrete controller.

A continuous plant ẋ = A x + B u(t − θ), position y = C x (numeric state space, input dead
time θ ≥ 0), or a discrete plant (A_d, B_d, C_d) with its own period, is sampled every T; a
discrete controller in state space (:class:`DiscreteController`, its matrices expressions
of T and the tunables) reads the reference, the sampled position and, for a cascade, the
sampled velocity; its output is held by a ZOH ``delay`` whole samples later. T may be a
tunable: the plant's transition e^{AT} and ∫₀ᵀe^{As}ds·B are CasADi expressions of T
(:func:`expm_function`), exact to rounding and differentiable.

:class:`SampledLTILoop` offers the Loop interface of :class:`feedtune.loop.SampledLoop`
(state matrices, characteristic polynomial, Schur conditions, C_v, frequency and error
responses at z = e^{jωT} up to Nyquist, exact step-error integrals between samples), so
the metrics and the tuner take it unchanged. The integrals are in
:mod:`feedtune.sampled_lti_integrals`.

References
----------
Koren 1979, sampled-data loop (Fig 4, eqs 14–19); Franklin, Powell & Workman, *Digital
Control of Dynamic Systems*, §4.3.4 (ZOH equivalent with a fractional input delay).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

from feedtune import linalg
from feedtune.lazy import ca, np
from feedtune.loop import (MAX_HORIZON_SAMPLES, SETTLE_FRACTION, SETTLED, Drive, HorizonError,
                           Interpolator, StepIntegrals, _LoopBase, _pole_pair)

#: Taylor degree of the exponential's core; with the scaled argument's 1-norm ≤ 1 the
#: truncation is ≤ e/19! ≈ 2e-17 of the norm, below double rounding (1.1e-16)
TAYLOR_DEGREE = 18
#: (z, T) pairs whose whole-sample count of a dead time may differ by this much (relative)
#: and still count as a whole number: rounding of θ/T for θ an exact multiple of T
WHOLE_SAMPLE_TOL = 1e-12
#: the controller's input columns, in this order
CONTROLLER_INPUTS = ("reference", "position", "velocity")


class SampledModelError(ValueError):
    """A plant, controller or dead time the sampled loop cannot take; names the field."""


def _float_matrix(value, name: str, shape=None) -> np.ndarray:
    array = np.atleast_2d(np.asarray(value, dtype=float))
    if not np.all(np.isfinite(array)):
        raise SampledModelError(f"{name}: not finite")
    if shape is not None and array.shape != shape:
        raise SampledModelError(f"{name}: shape {array.shape}, expected {shape}")
    return array


def balance(matrix) -> tuple:
    """(D⁻¹MD, d): a diagonal similarity by powers of two (exact in floating point) that
    equalises row and column norms (scipy.linalg.matrix_balance, no permutation). A drive's
    states mix units (rad, rad/s, A): ‖A‖₁ = 3e5 of a two-mass drive whose fastest mode is
    548 rad/s falls to 781."""
    from scipy.linalg import matrix_balance

    balanced, (scaling, _) = matrix_balance(np.asarray(matrix, dtype=float), permute=False,
                                            separate=True)
    return balanced, scaling


def expm_function(matrix, t_max: float) -> ca.Function:
    """``t ↦ e^{M t}`` for 0 ≤ t ≤ ``t_max`` [s] as a CasADi Function (SX, differentiable).

    Scaling and squaring with a Taylor core on the balanced M̃ = D⁻¹MD (:func:`balance`):
    s = ⌈log₂(‖M̃‖₁ t_max)⌉ squarings (fixed at build time from the largest t), so
    ‖M̃ t / 2^s‖₁ ≤ 1 for every t in the box, and the core Σ_{k≤18} (M̃ t/2^s)^k/k! is a
    matrix polynomial in the scalar t/t_max whose coefficient matrices are numbers computed
    once. Its truncation error is below e/19! ≈ 2e-17 of the norm; each squaring at most
    doubles the relative rounding (measured against scipy.linalg.expm in
    tests/unit/test_sampled_lti.py). ``casadi.expm`` is not usable (its plugin is missing
    from the wheel, docs/design.md numerical notes).
    """
    m, scaling = balance(matrix)
    n = m.shape[0]
    norm = float(np.linalg.norm(m, 1)) * t_max
    squarings = max(0, math.ceil(math.log2(norm))) if norm > 0 else 0
    scaled = m * t_max / 2**squarings
    coefficients = [np.eye(n)]
    for k in range(1, TAYLOR_DEGREE + 1):
        coefficients.append(coefficients[-1] @ scaled / k)
    t = ca.SX.sym("t")
    x = t / t_max
    result = ca.SX(ca.DM(coefficients[-1]))
    for c in reversed(coefficients[:-1]):  # Horner in the scalar x, entry by entry
        result = result * x + ca.DM(c)
    for _ in range(squarings):
        result = ca.mtimes(result, result)
    undo = ca.mtimes([ca.DM(np.diag(scaling)), result, ca.DM(np.diag(1 / scaling))])
    return ca.Function("expm", [t], [undo])


@dataclass(frozen=True)
class ContinuousPlant:
    """ẋ = A x + B u(t − θ), position y = C x + D u; SISO, numbers.

    Attributes
    ----------
    a, b, c, d
        State space (A n×n [1/s], B n×1, C 1×n, D 1×1; units of the drive's input and
        position). D must be 0: a position is never a direct feedthrough of a command.
    dead_time : float
        Input dead time θ ≥ 0 [s].
    dead_time_samples : float or None
        Alternatively θ = dead_time_samples·T (a dead time that scales with the period, as
        Sato's L = 1.5Δt_p); then ``dead_time`` must be 0.
    """

    a: object
    b: object
    c: object
    d: object = 0.0
    dead_time: float = 0.0
    dead_time_samples: float | None = None

    def __post_init__(self):
        a = _float_matrix(self.a, "/plant/a")
        n = a.shape[0]
        if a.shape != (n, n) or n == 0:
            raise SampledModelError(f"/plant/a: shape {a.shape}, expected square n×n, n ≥ 1")
        b = _float_matrix(np.reshape(self.b, (-1, 1)) if np.size(self.b) == n else self.b,
                          "/plant/b", (n, 1))
        c = _float_matrix(self.c, "/plant/c", (1, n))
        d = _float_matrix(self.d, "/plant/d", (1, 1))
        if d[0, 0] != 0:
            raise SampledModelError("/plant/d: must be 0 (the position output has no "
                                    "direct feedthrough of the drive's input)")
        if not (math.isfinite(self.dead_time) and self.dead_time >= 0):
            raise SampledModelError(f"/plant/dead_time: {self.dead_time} s, must be ≥ 0")
        if self.dead_time_samples is not None:
            if not (math.isfinite(self.dead_time_samples) and self.dead_time_samples >= 0):
                raise SampledModelError(f"/plant/dead_time_samples: {self.dead_time_samples}, "
                                        "must be ≥ 0")
            if self.dead_time != 0:
                raise SampledModelError("/plant/dead_time: give dead_time or "
                                        "dead_time_samples, not both")
        for name, value in (("a", a), ("b", b), ("c", c), ("d", d)):
            object.__setattr__(self, name, value)

    @property
    def order(self) -> int:
        return self.a.shape[0]

    @cached_property
    def velocity_row(self) -> np.ndarray:
        """C A: ẏ = C A x when C B = 0 (the position's relative degree is at least two)."""
        scale = float((np.abs(self.c) @ np.abs(self.b))[0, 0])  # Σ|c_i b_i|, C·B's own unit
        if abs(float((self.c @ self.b)[0, 0])) > 1e-12 * scale:  # C·B beyond its rounding
            raise SampledModelError("/plant: the velocity ẏ is measured as C A x, which needs "
                                    "C B = 0 (relative degree ≥ 2)")
        return self.c @ self.a

    def split_dead_time(self, period, period_box: tuple[float, float]):
        """(d, θ_f): θ = d·T + θ_f, d whole, 0 ≤ θ_f ≤ T, θ_f an expression of T [s].

        With T a tunable, d must be the same over the whole box [T_min, T_max]:
        ⌊θ/T_max⌋ = d and θ/T_min ≤ d + 1; θ_f = θ − d·T is then smooth in T. A dead time
        given in samples (θ = q·T) splits as d = ⌊q⌋, θ_f = (q − d)·T for any T.
        """
        if self.dead_time_samples is not None:
            q = self.dead_time_samples
            whole = math.floor(q + WHOLE_SAMPLE_TOL)
            fraction = max(q - whole, 0.0)
            return whole, (fraction * period if fraction > 0 else 0)
        theta = self.dead_time
        if theta == 0:
            return 0, 0
        low, high = period_box
        whole = math.floor(theta / high * (1 + WHOLE_SAMPLE_TOL))
        if theta / low > (whole + 1) * (1 + WHOLE_SAMPLE_TOL):
            raise SampledModelError(
                f"/plant/dead_time: θ = {theta:g} s spans {theta / high:g} to {theta / low:g} "
                f"samples over the sampling period's box [{low:g}, {high:g}] s; the whole "
                "number of samples must not change over the box (narrow the period's bounds, "
                "or give the dead time in samples)")
        fraction = theta - whole * period
        if low == high and abs(theta - whole * low) <= WHOLE_SAMPLE_TOL * theta:
            return whole, 0
        return whole, fraction


@dataclass(frozen=True)
class DiscretePlant:
    """x(k+1) = A_d x(k) + B_d u(k − delay_samples), position C_d x(k); period fixed [s].

    The intersample response is unknown, so no step-error integral is offered.
    """

    a: object
    b: object
    c: object
    d: object = 0.0
    period: float = 1e-3
    dead_time_samples: int = 0

    def __post_init__(self):
        a = _float_matrix(self.a, "/plant/a")
        n = a.shape[0]
        if a.shape != (n, n) or n == 0:
            raise SampledModelError(f"/plant/a: shape {a.shape}, expected square n×n, n ≥ 1")
        b = _float_matrix(np.reshape(self.b, (-1, 1)) if np.size(self.b) == n else self.b,
                          "/plant/b", (n, 1))
        c = _float_matrix(self.c, "/plant/c", (1, n))
        d = _float_matrix(self.d, "/plant/d", (1, 1))
        if d[0, 0] != 0:
            raise SampledModelError("/plant/d: must be 0 (no direct feedthrough to position)")
        if not (self.period > 0 and math.isfinite(self.period)):
            raise SampledModelError(f"/plant/period: {self.period} s, must be > 0")
        if int(self.dead_time_samples) != self.dead_time_samples or self.dead_time_samples < 0:
            raise SampledModelError("/plant/dead_time_samples: a discrete model takes a dead "
                                    "time of whole samples ≥ 0 only")
        for name, value in (("a", a), ("b", b), ("c", c), ("d", d)):
            object.__setattr__(self, name, value)

    @property
    def order(self) -> int:
        return self.a.shape[0]

    @cached_property
    def velocity_row(self):
        raise SampledModelError("/controller: a discrete plant has no velocity output; use "
                                "a controller of reference and position")


@dataclass(frozen=True)
class DiscreteController:
    """x_c(k+1) = A_c x_c + B_c w(k), u(k) = C_c x_c + D_c w(k), w = [r, y, v] at sample k.

    Matrices are CasADi expressions (of T and the tunables) or numbers; B_c has 3 columns
    and D_c is 1×3, in the order :data:`CONTROLLER_INPUTS` (reference, sampled position,
    sampled velocity). A static controller has a 0×0 A_c.
    """

    a: object
    b: object
    c: object
    d: object
    uses_velocity: bool = False  # whether the velocity column may be non-zero

    @property
    def order(self) -> int:
        return int(ca.MX(self.a).shape[0])


@dataclass(frozen=True, eq=False)
class SampledLTILoop(_LoopBase):
    """Sampled-data loop of an LTI plant, a ZOH and a discrete controller, exact between samples.

    State at sample k: [plant x (n), controller x_c, u(k−1), …, u(k−L)], with L the held
    commands still in flight: the computation delay c plus the dead time's whole samples
    d, plus one when a fractional part θ_f remains (the plant then sees u(k−c−d−1) for θ_f
    and u(k−c−d) for T − θ_f of each period; Franklin, Powell & Workman §4.3.4).

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
    """

    plant: ContinuousPlant | DiscretePlant
    controller: DiscreteController
    period: object
    period_box: tuple = (1e-3, 1e-3)
    delay: int = 0
    horizon: float = 1.0
    drive: Drive = field(default_factory=Drive)
    interpolator: Interpolator | None = None
    discrete = True

    def __post_init__(self):
        if int(self.delay) != self.delay or self.delay < 0:
            raise SampledModelError(f"/controller/delay: {self.delay}, must be a whole number "
                                    "of samples ≥ 0")
        low, high = self.period_box
        if not (0 < low <= high):
            raise SampledModelError(f"/tunables/sampling_period: box {self.period_box} s, "
                                    "need 0 < min ≤ max")
        if isinstance(self.plant, DiscretePlant):
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
        if isinstance(self.plant, DiscretePlant):
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
        """(e^{Ah}, ∫₀ʰe^{As}ds·B) over h [s] (ZOH, Franklin, Powell & Workman eq 4.58)."""
        n = self.plant.order
        e = self._hold_exponential(h)
        return e[:n, :n], e[:n, n]

    @cached_property
    def plant_transition(self):
        """(Φ, Γ₀, Γ₁): x(k+1) = Φx(k) + Γ₀u(k−c−d) + Γ₁u(k−c−d−1)."""
        if isinstance(self.plant, DiscretePlant):
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
        """(rows mapping x to [r-free y, v]): w = [r, C x, C A x]."""
        c = ca.DM(self.plant.c)
        velocity = (ca.DM(self.plant.velocity_row) if self.controller.uses_velocity
                    else ca.DM.zeros(1, self.plant.order))
        return c, velocity

    def command(self, lag: int):
        """(K, k): u(k − lag) = K·state + k·r, the command ``lag`` samples old."""
        n, nc, total = self.plant.order, self.controller.order, self.order
        if lag == 0:
            c, velocity = self._measurement
            dc = ca.MX(self.controller.d)
            kx = dc[0, 1] * c + dc[0, 2] * velocity
            row = ca.horzcat(kx, ca.MX(self.controller.c), ca.MX.zeros(1, self.held_samples))
            return row, dc[0, 0]
        row = ca.DM.zeros(1, total)
        row[0, n + nc + lag - 1] = 1
        return ca.MX(row), 0

    @cached_property
    def _matrices(self):
        n, nc, held = self.plant.order, self.controller.order, self.held_samples
        total = self.order
        phi_p, gamma0, gamma1 = self.plant_transition
        lag = self.delay + self._split[0]
        k0, r0 = self.command(lag)
        rows = [ca.horzcat(phi_p, ca.MX.zeros(n, total - n)) + ca.mtimes(gamma0, k0)]
        inputs = [gamma0 * r0]
        if self.has_fraction:
            k1, r1 = self.command(lag + 1)
            rows[0] = rows[0] + ca.mtimes(gamma1, k1)
            inputs[0] = inputs[0] + gamma1 * r1
        if nc:
            c, velocity = self._measurement
            bc = ca.MX(self.controller.b)
            x_part = ca.mtimes(bc[:, 1], c) + ca.mtimes(bc[:, 2], velocity)
            rows.append(ca.horzcat(x_part, ca.MX(self.controller.a), ca.MX.zeros(nc, held)))
            inputs.append(bc[:, 0])
        if held:
            k_now, r_now = self.command(0)
            shift = ca.horzcat(ca.DM.zeros(held - 1, n + nc), ca.DM.eye(held - 1),
                               ca.DM.zeros(held - 1, 1)) if held > 1 else ca.DM.zeros(0, total)
            rows += [k_now, ca.MX(shift)]
            inputs += [r_now, ca.MX.zeros(held - 1, 1)]
        return ca.vertcat(*rows), ca.vertcat(*[ca.MX(i) for i in inputs])

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

    def _resolvent(self, omega, rhs):
        n = self.order
        wt = omega * self.period
        re, im = linalg.complex_solve(ca.cos(wt) * ca.DM.eye(n) - self.state_matrix,
                                      ca.sin(wt) * ca.DM.eye(n), rhs)
        c = self.position_row
        return ca.mtimes(c, re), ca.mtimes(c, im)

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

    @cached_property
    def _equivalent_poles(self):
        _, c1, c0 = self.characteristic_polynomial
        return _pole_pair()(c1, c0)

    def natural_frequency(self):
        """ω_n [rad/s] of the pole pair s = ln(z)/T (order-2 loops, Koren eqs 17–19)."""
        return self._equivalent_poles[1] / self.period

    def damping_ratio(self):
        """ζ of the pole pair s = ln(z)/T (order-2 loops, Koren eq 19)."""
        return self._equivalent_poles[0]

    # -- step-error integrals -----------------------------------------------------------

    @property
    def has_exact_step_error(self) -> bool:
        """A continuous plant: its intersample error is integrated exactly."""
        return isinstance(self.plant, ContinuousPlant)

    @property
    def unrolled_steps(self) -> int:
        return self.horizon_samples if "step_error_integrals" in self.__dict__ else 0

    def settling_conditions(self) -> list:
        """Schur conditions of p(r·z), r = SETTLE_FRACTION^(1/N), once the step integrals are
        in use (as :meth:`feedtune.loop.SampledLoop.settling_conditions`)."""
        if "step_error_integrals" not in self.__dict__:
            return []
        radius = SETTLE_FRACTION ** (1 / self.horizon_samples)
        scaled = [c * radius ** (-k) for k, c in enumerate(self.characteristic_polynomial)]
        return linalg.hurwitz_conditions(linalg.bilinear_to_continuous(scaled))

    @cached_property
    def _numeric_spectral_radius(self) -> float | None:
        if ca.symvar(ca.veccat(ca.vec(ca.MX(self.state_matrix)), ca.MX(self.period))):
            return None
        return float(np.max(np.abs(np.linalg.eigvals(np.array(ca.evalf(self.state_matrix))))))

    @property
    def horizon_samples(self) -> int:
        """``horizon / T_min`` samples; a loop of numbers also runs until its free response
        decayed by SETTLED (as :attr:`feedtune.loop.SampledLoop.horizon_samples`)."""
        radius = self._numeric_spectral_radius
        if radius is None:
            return self._within_limit(math.ceil(self.horizon / self.period_min),
                                      MAX_HORIZON_SAMPLES)
        samples = math.ceil(self.horizon / float(ca.evalf(ca.MX(self.period))))
        if 0 < radius < 1:
            samples = max(samples, math.ceil(math.log(SETTLED) / math.log(radius)))
        return self._within_limit(samples, 10 * MAX_HORIZON_SAMPLES)

    def _within_limit(self, samples: int, limit: int) -> int:
        if samples > limit:
            raise HorizonError(
                f"a step response over {self.horizon:.3g} s at periods down to "
                f"{self.period_min:.3g} s needs {samples} samples (limit {limit})")
        return samples

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


# -- controllers ---------------------------------------------------------------------------

def _binomial_power(root_sign: float, power: int) -> list:
    """(z + root_sign)^power, highest power first."""
    out = [1]
    for _ in range(power):
        out = linalg.poly_mul(out, [1, root_sign])
    return out


def discretise_transfer(numerator: list, denominator: list, period, method: str = "tustin"):
    """(numerator, denominator) in z, highest power first, of a continuous C(s).

    ``tustin``: s = (2/T)(z − 1)/(z + 1), which maps the stable half plane onto the unit
    disc and the jω axis onto the unit circle (a stable C stays stable, second-order
    accurate, frequencies warped by tan(ωT/2)); the default. ``backward_euler``:
    s = (z − 1)/(T z), first order, how many drives implement their PI (the integrator
    sums e(k)·T). Coefficients are expressions of the tunables; C must be proper.
    """
    numerator, denominator = list(numerator), list(denominator)
    while len(denominator) > 1 and isinstance(denominator[0], (int, float)) and denominator[0] == 0:
        denominator.pop(0)
    n = len(denominator) - 1
    if len(numerator) - 1 > n:
        raise SampledModelError("/controller: improper transfer function (numerator degree "
                                f"{len(numerator) - 1} > denominator degree {n})")
    numerator = [0] * (n + 1 - len(numerator)) + numerator
    if method not in ("tustin", "backward_euler"):
        raise SampledModelError(f"/controller/method: {method!r}, expected 'tustin' or "
                                "'backward_euler'")

    def mapped(p):
        out = [0] * (n + 1)
        for i, coefficient in enumerate(p):  # coefficient of s^(n−i)
            power = n - i
            if method == "tustin":  # (2/T)^power (z − 1)^power (z + 1)^(n − power)
                term = linalg.poly_mul(_binomial_power(-1, power), _binomial_power(1, n - power))
                factor = coefficient * (2 / period) ** power
            else:  # (z − 1)^power (T z)^(n − power)
                term = _binomial_power(-1, power) + [0] * (n - power)
                factor = coefficient * period ** (n - power)
            out = linalg.poly_add(out, [factor * t for t in term])
        return out

    return mapped(numerator), mapped(denominator)


def transfer_state_space(numerator: list, denominator: list):
    """(A, B, C, D) of b(z)/a(z) (proper, same length, highest power first) in controllable
    canonical form, as MX; a static gain gives a 0×0 A."""
    lead = denominator[0]
    a = [c / lead for c in denominator]
    b = [c / lead for c in numerator]
    n = len(a) - 1
    d = b[0]
    if n == 0:
        return ca.MX(0, 0), ca.MX(0, 1), ca.MX(1, 0), ca.MX(d)
    matrix = linalg.companion_matrix(a)
    c = ca.horzcat(*[b[i + 1] - d * a[i + 1] for i in range(n)])
    b_col = ca.vertcat(1, ca.DM.zeros(n - 1, 1))
    return ca.MX(matrix), ca.MX(b_col), ca.MX(c), ca.MX(d)


def error_controller(numerator: list, denominator: list, period, method: str = "tustin"):
    """u = C(z)·(r − y): a continuous C(s) discretised (:func:`discretise_transfer`)."""
    a, b, c, d = transfer_state_space(*discretise_transfer(numerator, denominator, period, method))
    weights = ca.DM([[1, -1, 0]])  # w = [r, y, v] → e = r − y
    return DiscreteController(a, ca.mtimes(b, weights), c, ca.mtimes(d, weights))


def cascade_controller(position_gain, velocity_numerator: list, velocity_denominator: list,
                       period, method: str = "tustin", feedforward: bool = False):
    """P position loop around a velocity controller (e.g. PI K(1 + 1/(T_i s))).

    v_ref = K_p(r − y) (+ the reference's backward difference (r(k) − r(k−1))/T with
    ``feedforward``, not offered yet), u = C_v(z)·(v_ref − v); K_p [1/s], v the sampled
    velocity C A x.
    """
    if feedforward:
        raise NotImplementedError("velocity feed-forward is not implemented")
    a, b, c, d = transfer_state_space(
        *discretise_transfer(velocity_numerator, velocity_denominator, period, method))
    weights = ca.horzcat(position_gain, -position_gain, -1)  # v_ref − v
    return DiscreteController(a, ca.mtimes(b, weights), c, ca.mtimes(d, weights),
                              uses_velocity=True)
