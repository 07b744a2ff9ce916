"""Closed-loop models: what plants produce and what metrics read.

A Loop's numbers are CasADi expressions of the tunable parameters, so one Loop serves
the NLP (symbols) and the evaluation of a tuned design (numbers). Three kinds exist:

* :class:`ContinuousLoop` — ẋ = A x + B r, position y = C x (Koren's reference-pulse loop);
* :class:`SampledLoop` — a continuous :class:`IntegratorLag` (or ideal :class:`Integrator`)
  plant behind a zero-order hold, position sampled every T, a proportional position
  controller with an integer computation delay (Koren's sampled-data loop, Fig 4; Sato's
  software servo, Fig 1), discretised exactly;
* :class:`TransferLoop` — a continuous loop given by polynomials in s.

All give the characteristic polynomial, stability conditions and the frequency response
from reference to position; Koren's loops also exact step-error integrals. A loop whose
reference comes from a linear interpolator carries its :class:`Interpolator`.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from functools import cached_property, lru_cache

from feedtune.expr import is_symbolic, to_float
from feedtune.lazy import ca, np
from feedtune.loops import linalg
from feedtune.loops.protocols import Capability, DeclaredCapabilities
from feedtune.loops.twin import replayed_expressions, replayed_numbers
from feedtune.loops.signals import (ErrorIntegrals, sample_error_integrals, sample_moments,
                                    second_order_error_integrals)

MAX_HORIZON_SAMPLES = 50_000
SETTLED = 1e-13  # a numeric loop's step response is summed until its modes decay this far
SETTLE_FRACTION = 1e-4  # a symbolic loop's modes must decay this far within its horizon


class HorizonError(ValueError):
    """A step response would need more samples than MAX_HORIZON_SAMPLES."""


def at_shared_omega(method):
    """A loop's response method ``method(self, omega)`` kept per loop at the shared ω of
    the frequency Functions (:func:`feedtune.loops.frequency.is_shared_omega`): the peaks
    and crossings of one loop build each response once (same expression, same bits)."""
    @functools.wraps(method)
    def response(self, omega):
        from feedtune.loops.frequency import is_shared_omega

        if not is_shared_omega(omega):
            return method(self, omega)
        kept = self.__dict__.setdefault("_shared_responses", {})  # (name, SX or MX) → value
        key = (method.__name__, type(omega).__name__)
        if key not in kept:
            kept[key] = method(self, omega)
        return kept[key]

    return response


class EmbeddedNumber:
    """A dataclass field of a loop whose number may shape the loop's graph (a horizon's
    sample count, a frequency grid) rather than enter it as arithmetic: every read is
    recorded for the loop's :meth:`~feedtune.loops.protocols.DeclaredCapabilities.embedded_reads`,
    so the tuner's structure
    cache (feedtune.tuner.cache.StructureKey) separates loops only by the numbers their
    graph read. Set on the class after ``@dataclass``, which then initialises the field
    through it."""

    def __init__(self, name: str):
        self.name = name

    def __get__(self, loop, owner=None):
        if loop is None:
            return self
        loop.__dict__.setdefault("_embedded_reads", set()).add(self.name)
        return loop.__dict__[self.name]

    def __set__(self, loop, value):
        loop.__dict__[self.name] = value


class StepIntegrals:
    """IAE [m·s], ISE [m²·s] and ITAE [m·s²] of a step response, each built when first read.

    ``build(name)`` returns the integral named ``iae``, ``ise`` or ``itae``. Reads and
    iterates like :class:`~feedtune.loops.signals.ErrorIntegrals` (iae, ise, itae).
    """

    _NAMES = ErrorIntegrals._fields

    def __init__(self, build):
        self._build = build
        self._values = {}

    def _get(self, name):
        if name not in self._values:
            self._values[name] = self._build(name)
        return self._values[name]

    iae = property(lambda self: self._get("iae"))
    ise = property(lambda self: self._get("ise"))
    itae = property(lambda self: self._get("itae"))

    def __iter__(self):
        return (self._get(name) for name in self._NAMES)


@lru_cache(maxsize=None)
def _sample_step(order: int, name: str | tuple[str, ...]) -> ca.Function:
    """One sample of a sampled loop with an integrator-lag plant, accumulating integrals.

    ``step(state, Φ, Γ, k_x, k_r, T, τ)`` with state [plant and buffer states (``order``),
    ∫ so far, t] returns the state one sample later; the integral is ``name`` (iae, ise or
    itae) of the error α + βs + γe^{−s} over the sample (:func:`sample_error_integrals`).
    ``name`` a tuple of those names: one ∫ so far per name, in its order (a loop of
    numbers sums all three in one pass: the state's recurrence and the sample's cuts,
    which IAE and ITAE share, once; each ∫ the same operations on the same numbers as its
    own step's, so the same bits).
    Built once per process: the same Function serves every loop, so graphs of equal
    structure serialize alike (the tuner's solver cache) and no loop pays for the build.
    """
    n = order
    names = (name,) if isinstance(name, str) else tuple(name)
    tau = ca.SX.sym("tau")  # an input, so τ may be a number or an expression
    state = ca.SX.sym("state", n + len(names) + 1)  # [x, v, buffer..., integrals, t]
    phi_s = ca.SX.sym("phi", n, n)
    gamma_s = ca.SX.sym("gamma", n)
    kx_s = ca.SX.sym("kx", 1, n)
    kr_s = ca.SX.sym("kr")
    period_s = ca.SX.sym("period")
    xi = state[:n]
    u = ca.mtimes(kx_s, xi) + kr_s
    position, velocity = xi[0], xi[1]
    alpha = 1 - position - (velocity - u) * tau
    beta = -u * tau
    gamma = (velocity - u) * tau
    t = state[n + len(names)]
    pieces = sample_error_integrals(alpha, beta, gamma, period_s / tau, tau, t)
    nxt = ca.vertcat(ca.mtimes(phi_s, xi) + gamma_s,
                     *(state[n + i] + getattr(pieces, one) for i, one in enumerate(names)),
                     t + period_s)
    return ca.Function(f"sample_{'_'.join(names)}",
                       [state, phi_s, gamma_s, kx_s, kr_s, period_s, tau], [nxt])


@lru_cache(maxsize=512)
def _buffered(fn: ca.Function):
    """``fn`` called through its evaluation buffer (:class:`feedtune.loops.frequency.Buffered`:
    numpy arrays in and out, ≈ 2 µs a call instead of ≈ 60–100 µs through DM conversions;
    the same evaluation, so the same bits), kept per Function (one per fold size and
    integral: a loop of numbers sums its horizon through a handful of them)."""
    from feedtune.loops.frequency import Buffered  # the frequency module, when first summed

    return Buffered(fn)


@lru_cache(maxsize=256)
def _sample_fold(order: int, name: str | tuple[str, ...], samples: int) -> ca.Function:
    """:func:`_sample_step` folded over ``samples`` samples (2.5 ms to build: kept for the
    loops that follow, of the same structure)."""
    return _sample_step(order, name).fold(samples)


def _binary_chunks(samples: int) -> list[int]:
    """``samples`` as a sum of powers of two, largest first (13 → [8, 4, 1]).

    A loop of numbers sums its horizon (a count that varies with every loop's spectral
    radius) through folds of these sizes one after the other: the same samples in the same
    order, so the same bits as one fold of ``samples``, but at most ≈ 20 folds per
    structure are ever built (a fold of a new size cost ≈ 2.5 ms, on every spec of a batch).
    """
    return [1 << bit for bit in range(samples.bit_length() - 1, -1, -1) if samples >> bit & 1]


@lru_cache(maxsize=None)
def _tail(order: int, name: str | tuple[str, ...]) -> ca.Function:
    """∫e, ∫e² or ∫t·e (``name`` iae, ise or itae) of a sampled integrator-lag loop from a
    sample to infinity.

    ``tail(state, t, Φ, Γ, k_x, T, τ)`` at sample state ``state`` and time ``t`` [s]. With
    δ the distance to the settled state, each sample's ∫e dt and ∫σe dσ are linear in δ
    (rows c1, c2) and ∫e² dt is δᵀQδ (:func:`sample_moments`); summing over δ(k) = Φ^k δ
    gives (I − Φ)^{-1}, Φ(I − Φ)^{-2} and a discrete Lyapunov equation. Returns the signed
    ∫e [m·s], ∫e² [m²·s] or the signed ∫t·e [m·s²], only that one: expanding a graph
    evaluates every output of the Functions it calls. ``name`` a tuple of those names:
    one output per name, in its order (a loop of numbers, :func:`_sample_step`). Built
    once per process, as :func:`_sample_step`.
    """
    n = order
    state, start_time = ca.SX.sym("state", n), ca.SX.sym("t")
    phi, gamma_cl = ca.SX.sym("phi", n, n), ca.SX.sym("gamma", n)
    kx, period, tau = ca.SX.sym("kx", 1, n), ca.SX.sym("period"), ca.SX.sym("tau")
    eye = ca.DM.eye(n)
    delta = state - ca.solve(eye - phi, gamma_cl)
    e_x = ca.horzcat(1, ca.DM.zeros(1, n - 1))
    e_v = ca.horzcat(0, 1, ca.DM.zeros(1, n - 2))
    # α, β, γ of the intersample error as rows acting on δ (zero at the settled state)
    a_row = -e_x - tau * (e_v - kx)
    b_row = -tau * kx
    g_row = tau * (e_v - kx)
    c1, c2, q = sample_moments(a_row, b_row, g_row, period / tau, tau)
    geometric = ca.solve(eye - phi, ca.SX(eye))  # Σ Φ^k
    weighted = ca.mtimes([phi, geometric, geometric])  # Σ k Φ^k
    lyapunov = ca.solve(ca.DM.eye(n * n) - ca.kron(phi.T, phi.T), ca.vec(q))
    p = ca.reshape(lyapunov, n, n)
    sum_e = ca.mtimes([c1, geometric, delta])
    tails = {"iae": sum_e, "ise": ca.mtimes([delta.T, p, delta]),
             "itae": (start_time * sum_e + period * ca.mtimes([c1, weighted, delta])
                      + ca.mtimes([c2, geometric, delta]))}
    names = (name,) if isinstance(name, str) else tuple(name)
    return ca.Function(f"tail_{'_'.join(names)}",
                       [state, start_time, phi, gamma_cl, kx, period, tau],
                       [tails[one] for one in names])


@lru_cache(maxsize=None)
def _pole_pair() -> ca.Function:
    """(ζ, ω_n·T) of the pole pair of z² + c1·z + c0, mapped by s = ln(z)/T.

    Complex pair a·e^{±jθ}: ζ = −ln a/√(ln²a + θ²), ω_nT = √(ln²a + θ²) (Koren eqs
    17–19). Positive real pair: the overdamped second order with s_i = ln z_i/T,
    ζ = −(ln z1 + ln z2)/(2√(ln z1 ln z2)) ≥ 1. A negative real pole rings at the
    Nyquist frequency: the principal branch ln|z| ± jπ of the most negative pole (the
    least damped one) gives ζ and ω_n. Built once per process, as :func:`_sample_step`,
    so a loop of numbers evaluates it without building a graph.
    """
    c1, c0 = ca.SX.sym("c1"), ca.SX.sym("c0")
    tiny = 1e-300
    discriminant = c1**2 - 4 * c0
    a = ca.sqrt(ca.fmax(c0, tiny))
    cosine = ca.fmin(ca.fmax(-c1 / (2 * a), -1), 1)
    # θ = acos(cosine), written so that no derivative is infinite at cosine = ±1 (a branch
    # not taken still multiplies its derivatives by zero in reverse mode: 0·∞ is NaN)
    theta = ca.atan2(ca.sqrt(ca.fmax(1 - cosine**2, tiny)), cosine)
    complex_wn = ca.sqrt(ca.log(a) ** 2 + theta**2)
    complex_zeta = -ca.log(a) / complex_wn
    root = ca.sqrt(ca.fmax(discriminant, tiny))  # tiny, not 0: keeps d√ finite
    z1, z2 = (-c1 + root) / 2, (-c1 - root) / 2  # z1 ≥ z2
    ln1, ln2 = ca.log(ca.fmax(z1, tiny)), ca.log(ca.fmax(z2, tiny))
    real_wn = ca.sqrt(ln1 * ln2)
    real_zeta = -(ln1 + ln2) / (2 * real_wn)
    ln_abs = ca.log(ca.fmax(ca.fabs(z2), tiny))
    nyquist_wn = ca.sqrt(ln_abs**2 + ca.pi**2)
    nyquist_zeta = -ln_abs / nyquist_wn
    zeta = ca.if_else(discriminant < 0, complex_zeta,
                      ca.if_else(z2 > 0, real_zeta, nyquist_zeta))
    wn = ca.if_else(discriminant < 0, complex_wn, ca.if_else(z2 > 0, real_wn, nyquist_wn))
    return ca.Function("pole_pair", [c1, c0], [zeta, wn])


def _numbers(values: list) -> list | None:
    """``values`` (expressions) as DM numbers, evaluated in one Function; None when any
    holds a symbol (a loop inside the NLP). Values that are all DM already are returned
    as they are (what the Function would return, without building it)."""
    if all(isinstance(v, ca.DM) for v in values):
        return list(values)
    try:
        function = ca.Function("numbers", [], [ca.MX(v) for v in values])
    except RuntimeError as exc:
        if "are free" in str(exc):
            return None
        raise
    return function.call([])


def _matrix_and_polynomial(loop) -> list:
    """[state matrix, c_n, …, c_0] of ``loop`` (expressions)."""
    return [loop.state_matrix, *loop.characteristic_polynomial]


def _hold_values(loop) -> list:
    """[Φ, Γ, k_x, k_r, T] of a :class:`SampledLoop`, and τ for a drive with a time
    constant (expressions)."""
    phi, gamma, kx, kr = loop._matrices
    values = [phi, gamma, kx, kr, loop.period]
    if loop.plant.time_constant is not None:
        values.append(loop.plant.time_constant)
    return values


def _poly_on_circle(p: list, theta):
    """Re and Im of p(e^{jθ}), highest power first: Σ c_k (cos kθ + j sin kθ)."""
    degree = len(p) - 1
    re, im = 0, 0
    for i, c in enumerate(p):
        k = degree - i
        if k == 0:
            re = re + c
        else:
            re, im = re + c * ca.cos(k * theta), im + c * ca.sin(k * theta)
    return re, im


def _ratio_on_circle(numerator: list, denominator: list, theta):
    """Re and Im of numerator/denominator at z = e^{jθ} (polynomials, highest power first)."""
    n_re, n_im = _poly_on_circle(numerator, theta)
    d_re, d_im = _poly_on_circle(denominator, theta)
    d2 = d_re**2 + d_im**2
    return (n_re * d_re + n_im * d_im) / d2, (n_im * d_re - n_re * d_im) / d2


@dataclass(frozen=True)
class Drive:
    """Physical data of the axis that some metrics need, beyond the loop dynamics.

    Each number may also be a CasADi expression (a plant's number lifted into an NLP
    parameter, see ``feedtune.plants.base``); metrics only compute with them.

    Attributes
    ----------
    time_constant : float or None
        Time constant τ [s] of a first-order velocity drive (Koren eq 3), if the drive is one.
    blu : float or None
        Basic length unit, one encoder pulse [m].
    max_velocity : float or None
        Maximum axis velocity V_m [m/s].
    counter_bits : int or None
        Width of the feedback counter read every sample, sign bit included.
    """

    time_constant: float | None = None
    blu: float | None = None
    max_velocity: float | None = None
    counter_bits: int | None = None

    @property
    def max_pulse_rate(self) -> float | None:
        """f_m = V_m / BLU [pulses/s] (Koren eq 1)."""
        if self.blu is None or self.max_velocity is None:
            return None
        return self.max_velocity / self.blu


@dataclass(frozen=True)
class Interpolator:
    """A path sent to the servo as a polygon (Sato et al., Figs 2–3).

    The interpolator puts a point on the path every ``reference_interval`` T [s]; the servo
    steps along each chord every ``sampling_period`` Δt_p [s]. Both are expressions of the
    tunables.
    """

    reference_interval: object
    sampling_period: object

    @property
    def steps_per_interval(self):
        """q = T/Δt_p [1], servo steps per chord (Sato §3.2.1)."""
        return self.reference_interval / self.sampling_period


@dataclass(frozen=True)
class Integrator:
    """Ideal velocity drive: position is the integral of the velocity command; state [position].

    Sato et al. Fig 1 (the velocity loop is taken as much faster than the position loop).
    """

    time_constant = None
    order = 1

    def discretise(self, period):
        """Exact zero-order-hold transition (Φ, Γ) = (1, T) over one period T [s]."""
        return ca.DM([[1]]), ca.vertcat(period)


@dataclass(frozen=True)
class IntegratorLag:
    """Velocity drive 1/(1 + sτ) integrating to position; states [position, velocity].

    Koren eqs 3–4 with the drive constant K_m folded into the loop gain. ``time_constant``
    τ [s] is a number or an expression (a plant's number lifted into an NLP parameter).
    """

    time_constant: object
    order = 2

    def discretise(self, period):
        """Exact zero-order-hold transition (Φ, Γ) over one period T [s]."""
        tau = self.time_constant
        x = ca.exp(-period / tau)  # X of Koren eq 18
        phi = ca.vertcat(ca.horzcat(1, tau * (1 - x)), ca.horzcat(0, x))
        gamma = ca.vertcat(period - tau * (1 - x), 1 - x)
        return phi, gamma


class _LoopBase(DeclaredCapabilities):
    """Shared algebra of the linear loops; subclasses set the matrices and declare their
    capabilities (:mod:`feedtune.loops.protocols`)."""

    exact_only = False
    discrete: bool
    state_matrix: object
    input_matrix: object
    position_row: object
    interpolator: Interpolator | None = None

    @property
    def order(self) -> int:
        return self.state_matrix.shape[0]

    def sensitivity_response(self, omega):
        """Re and Im of the feedback loop's S = 1/(1 + L) at ω [rad/s]: the error per
        reference of a unity-feedback loop (``error_response``); a loop whose reference path
        differs (a velocity feed-forward) overrides it."""
        return self.error_response(omega)

    @property
    def unrolled_steps(self) -> int:
        """Loop steps inside the expressions built so far (a cost hint for the tuner)."""
        return 0

    @cached_property
    def characteristic_polynomial(self) -> list:
        """Monic closed-loop characteristic polynomial, highest power first.

        A loop of numbers whose structure's Function of :attr:`_matrix_and_polynomial_numbers`
        is built takes the coefficients from a call of it in the graph (issue 15: the
        recursion's graph cost ≈ 0.5 ms a tuned design), the same operations, so the same
        bits and the same simplifications above them."""
        replayed = replayed_expressions(self, "matrix_and_polynomial")
        if replayed is not None:
            return replayed[1:]
        return linalg.characteristic_polynomial(self.state_matrix)

    @cached_property
    def _matrix_and_polynomial_numbers(self) -> list | None:
        """[state matrix, c_n, …, c_0] as DM numbers, evaluated together once per loop (one
        Function: the same operations, the same bits); None for a loop of symbols."""
        return (replayed_numbers(self, "matrix_and_polynomial", _matrix_and_polynomial)
                or _numbers(_matrix_and_polynomial(self)))

    @cached_property
    def _polynomial_numbers(self) -> list | None:
        """The characteristic polynomial's coefficients as DM numbers (read by the stability
        conditions, the damping ratio and the step integrals' check: evaluated once, issue
        15); None for a loop of symbols."""
        numbers = self._matrix_and_polynomial_numbers
        return None if numbers is None else numbers[1:]

    @cached_property
    def _state_numbers(self):
        """The state matrix as a DM, evaluated once per loop; None for a loop of symbols."""
        numbers = self._matrix_and_polynomial_numbers
        return None if numbers is None else numbers[0]

    def numeric_state_matrix(self) -> "np.ndarray | None":
        """The state matrix's numbers as a float array (a copy), or None for a loop of
        symbols (inside the NLP). Evaluated once per loop (issue 15: the pole metrics, the
        spectral radius and the stability check each evaluated it); the numbers of
        ``casadi.evalf`` of the matrix, the same evaluation."""
        numbers = self._state_numbers
        return None if numbers is None else np.array(numbers, dtype=float)

    def natural_frequency(self):
        """ω_n = √a0 [rad/s] of s² + a1 s + a0 (continuous second-order loops; Koren eq 10)."""
        return ca.sqrt(self.characteristic_polynomial[2])

    def damping_ratio(self):
        """ζ = a1 / (2√a0) of s² + a1 s + a0 (continuous second-order loops; Koren eq 9).
        On a loop of numbers the same operations on the coefficients' numbers (a DM: no
        graph to evaluate a second time)."""
        numbers = self._polynomial_numbers
        _, a1, a0 = self.characteristic_polynomial if numbers is None else numbers
        return a1 / (2 * ca.sqrt(a0))

    def settling_conditions(self) -> list:
        """Expressions positive iff the loop settles within the horizon its metrics sum over.

        Empty unless a metric summed a response over a finite horizon (see SampledLoop).
        """
        return []

    def stability_matrices(self) -> dict:
        """Matrices whose eigenvalues must all be stable, by name; the closed loop first.

        Loops with an inner loop that must be stable on its own add it here. A loop of
        numbers gives the closed loop's numbers (a DM: the evaluation
        :meth:`numeric_state_matrix` reads, once per loop), so a tuned design's check does
        not evaluate the matrix a second time (issue 15).
        """
        numbers = self._state_numbers
        return {"closed_loop": self.state_matrix if numbers is None else numbers}

    def stability_conditions(self) -> list:
        """Expressions all positive iff the closed loop is asymptotically stable.

        Hurwitz (Liénard–Chipart) conditions; for a sampled loop, of the polynomial mapped
        by z = (1 + w)/(1 − w), so the same test reads the unit circle.
        """
        poly = self.characteristic_polynomial
        numbers = self._polynomial_numbers
        if numbers is not None:  # a loop of numbers: the same operations on floats, no
            # graph (a scalar DM operation is the IEEE operation on doubles that Python's
            # float does, without ≈ 10-20 µs of CasADi's call a DM operation: the sampled
            # loop's map to the w-plane cost ≈ 0.5 ms a tuned design on DM)
            poly = [float(c) for c in numbers]
        if self.discrete:
            poly = linalg.bilinear_to_continuous(poly)
        if numbers is not None:
            return linalg.hurwitz_conditions_of_numbers(poly)
        return linalg.hurwitz_conditions(poly)


@dataclass(frozen=True, eq=False)
class ContinuousLoop(_LoopBase):
    """Continuous closed loop ẋ = A x + B r, position = C x.

    Attributes
    ----------
    state_matrix, input_matrix, position_row
        A, B, C of the closed loop from the position reference r [m] to position [m].
    velocity_constant
        C_v = lim s·G_open(s) [1/s], the open-loop gain of a type-1 loop (Koren eq 5).
    drive : Drive
    open_loop : tuple or None
        (numerator, denominator) of the open loop L, highest power first, when the loop is
        L closed by unity feedback (Koren's K/(s(1 + sτ)), eq 5): the frequency metrics'
        L(jω) (margins, crossover); None: no open loop is known.
    frequency_band : tuple or None
        (low, high) [rad/s] the frequency metrics search; None: none is supported.
    """

    state_matrix: object
    input_matrix: object
    position_row: object
    velocity_constant: object
    drive: Drive = field(default_factory=Drive)
    open_loop: tuple | None = None
    frequency_band: tuple | None = None
    discrete = False
    period = None
    capabilities = frozenset({Capability.LINEAR, Capability.VELOCITY_CONSTANT,
                              Capability.EXACT_STEP_ERROR, Capability.FREQUENCY_RESPONSE,
                              Capability.OPEN_LOOP})

    @at_shared_omega
    def open_loop_response(self, omega):
        """Re and Im of L(jω), ω [rad/s], from :attr:`open_loop`."""
        numerator, denominator = self.open_loop
        return TransferLoop._ratio(numerator, denominator, omega)

    def dc_gain(self):
        """T(0) = −C A⁻¹ B [1] (1 for a loop that follows a constant reference)."""
        return -ca.mtimes(self.position_row, linalg.solve(self.state_matrix, self.input_matrix))

    @at_shared_omega
    def frequency_response(self, omega):
        """Re and Im of position/reference at s = jω, ω [rad/s]."""
        n = self.order
        re, im = linalg.complex_solve(-self.state_matrix, omega * ca.DM.eye(n), self.input_matrix)
        return ca.mtimes(self.position_row, re), ca.mtimes(self.position_row, im)

    @at_shared_omega
    def error_response(self, omega):
        """Re and Im of S = 1 − H at s = jω, without the cancellation of 1 − H at low ω.

        For a loop that follows a constant reference exactly (C A⁻¹ B = −1),
        S(s) = −s·C(sI − A)⁻¹A⁻¹B.
        """
        n = self.order
        re, im = linalg.complex_solve(-self.state_matrix, omega * ca.DM.eye(n), self._settled)
        c_re, c_im = ca.mtimes(self.position_row, re), ca.mtimes(self.position_row, im)
        return omega * c_im, -omega * c_re  # −jω·(c_re + j c_im)

    @cached_property
    def _settled(self):
        """A⁻¹B, built once per loop: every response of S reads the same expression."""
        return linalg.solve(self.state_matrix, self.input_matrix)

    @property
    def has_exact_step_error(self) -> bool:
        return self.order == 2

    @cached_property
    def step_error_integrals(self) -> ErrorIntegrals:
        """Exact IAE/ISE/ITAE of the error after a 1 m position step (second-order loops)."""
        if self.order != 2:
            raise NotImplementedError("exact step-error integrals need a second-order loop")
        _, a1, a0 = self.characteristic_polynomial
        numbers = self._polynomial_numbers  # evaluated once per loop
        if numbers is not None and not (float(numbers[1]) > 0 and float(numbers[2]) > 0):
            return ErrorIntegrals(math.inf, math.inf, math.inf)  # unstable: never settles
        # e = 1 − C x, x(0) = 0: e(0) = 1, ė(0) = −C B
        de0 = -ca.mtimes(self.position_row, self.input_matrix)
        return second_order_error_integrals(a1, a0, 1.0, de0)


class _SampledLoopBase(_LoopBase):
    """What every sampled-data loop derives the same way from its state matrix, its
    characteristic polynomial in z, ``period``, ``period_min`` and ``horizon``: the
    equivalent s-plane pole pair, the step integrals' horizon and their settling conditions
    (Koren's :class:`SampledLoop`, the general
    :class:`feedtune.loops.sampled_lti.SampledLTILoop`). Each subclass builds
    ``_matrices``, whose first two entries are Φ_cl and Γ_cl."""

    @property
    def state_matrix(self):
        """Φ_cl: state(k+1) = Φ_cl state(k) + Γ_cl r(k)."""
        return self._matrices[0]

    @property
    def input_matrix(self):
        """Γ_cl: the column by which the reference r(k) enters the state."""
        return self._matrices[1]

    @cached_property
    def characteristic_polynomial(self) -> list:
        """Monic closed-loop characteristic polynomial in z, highest power first.

        A loop of numbers evaluates Φ_cl once and runs the recursion on DM (issue 15:
        ≈ 0.7 ms of MX graph building and evaluation a tuned design's reports otherwise):
        the same operations on the same numbers. Its readers here take the coefficients
        through Functions (:func:`_pole_pair`, the Hurwitz conditions of numbers) or as
        numbers, so every value keeps its bits. (A continuous loop keeps its graph: there
        ω_n = √c0 squared in natural-time ITAE folds to c0 on the graph, not on numbers.)"""
        numbers = self._state_numbers  # (its graph not built for a loop of numbers)
        return linalg.characteristic_polynomial(self.state_matrix if numbers is None else numbers)

    @cached_property
    def _state_numbers(self):
        """Φ_cl as a DM, evaluated once per loop (its polynomial is computed from it); None
        for a loop of symbols."""
        numbers = _numbers([self.state_matrix])
        return None if numbers is None else numbers[0]

    @cached_property
    def _polynomial_numbers(self) -> list | None:
        """The characteristic polynomial's coefficients as DM numbers: computed from Φ_cl's
        numbers already (:attr:`characteristic_polynomial`); None for a loop of symbols."""
        return _numbers(self.characteristic_polynomial)

    @cached_property
    def _equivalent_poles(self):
        """(ζ, ω_n·T) of the closed-loop pole pair (:func:`_pole_pair`); order-2 loops."""
        _, c1, c0 = self.characteristic_polynomial
        return _pole_pair()(c1, c0)

    def natural_frequency(self):
        """ω_n [rad/s] of the equivalent s-plane poles s = ln(z)/T (Koren eqs 17–19)."""
        return self._equivalent_poles[1] / self.period

    def damping_ratio(self):
        """ζ = αT / √((αT)² + (ωT)²), Koren eq 19, extended to real pole pairs."""
        return self._equivalent_poles[0]

    @property
    def unrolled_steps(self) -> int:
        return self.horizon_samples if "step_error_integrals" in self.__dict__ else 0

    def settling_conditions(self) -> list:
        """Every pole inside |z| < SETTLE_FRACTION^(1/N), N = horizon_samples, once the step
        integrals are in use: positive iff a mode left after the summed samples is below
        SETTLE_FRACTION of its start.

        The closed-form tail is exact only for an error that no longer changes sign; a loop
        still ringing at the horizon would look better than it is, and an optimiser would
        drift towards it. Schur conditions of p(r·z) (a pole-margin bound) keep it honest;
        the tuner lengthens the horizon when they bind.
        """
        if "step_error_integrals" not in self.__dict__:
            return []
        radius = SETTLE_FRACTION ** (1 / self.horizon_samples)
        poly = self.characteristic_polynomial
        scaled = [c * radius ** (-k) for k, c in enumerate(poly)]  # monic p(r z)/r^n
        return linalg.hurwitz_conditions(linalg.bilinear_to_continuous(scaled))

    @cached_property
    def _numeric_spectral_radius(self) -> float | None:
        """max |pole| when the loop holds numbers only, else None (symbolic)."""
        matrix = self.numeric_state_matrix()
        if matrix is None or is_symbolic(self.period):
            return None
        return float(np.max(np.abs(np.linalg.eigvals(matrix))))

    @property
    def horizon_samples(self) -> int:
        """Samples summed one by one before the closed-form tail.

        Symbolic loops: ``horizon / period_min``. Loops of numbers also run until the free
        response has decayed by SETTLED (from the spectral radius), so what a result
        reports is exact even for lightly damped loops.
        """
        radius = self._numeric_spectral_radius
        if radius is None:
            return self.symbolic_horizon_samples
        samples = self.horizon / to_float(self.period)
        if 0 < radius < 1:
            samples = max(samples, math.log(SETTLED) / math.log(radius))
        return self._within_limit(samples, 10 * MAX_HORIZON_SAMPLES)

    @property
    def symbolic_horizon_samples(self) -> int:
        """:attr:`horizon_samples` of this loop built on symbols, ``horizon / period_min``,
        from the numbers alone (no expression is built)."""
        return self._within_limit(self.horizon / self.period_min, MAX_HORIZON_SAMPLES)

    def _within_limit(self, samples: float, limit: int) -> int:
        """``samples`` rounded up, or HorizonError when above ``limit`` or not finite (a
        horizon beyond double precision, e.g. from τ = 1e306 s)."""
        if not samples <= limit:
            count = math.ceil(samples) if math.isfinite(samples) else samples
            raise HorizonError(
                f"a step response over {self.horizon:.3g} s at periods down to "
                f"{self.period_min:.3g} s needs {count} samples (limit "
                f"{limit}); raise the minimum sampling period or gain")
        return math.ceil(samples)


@dataclass(frozen=True, eq=False)
class SampledLoop(_SampledLoopBase):
    """Sampled-data position loop (Koren Fig 4), exact between samples.

    Every period T the position is sampled, the error e(n) = r − x(nT) times the gain K
    becomes the velocity command, which a zero-order hold applies ``delay`` periods later.
    State at sample n: [plant states, c(n−1), ..., c(n−delay)], the plant's states being
    [position, velocity] (IntegratorLag) or [position] (Integrator).

    Attributes
    ----------
    plant : IntegratorLag or Integrator
    gain : expression
        Position-loop gain K [1/s] (Koren eq 5).
    period : expression
        Sampling period T [s].
    delay : int
        Computation delay in whole samples.
    drive : Drive
    horizon : float
        Time [s] after which every loop in the tuning box has settled; step integrals are
        summed over ``horizon / period_min`` samples.
    period_min : float
        Smallest period [s] the tuner may choose.
    interpolator : Interpolator or None
    frequency_band : tuple or None
        (low, high) [rad/s] numbers: ``low`` below every corner of the loop, ``high``
        above the Nyquist frequency π/T of every period in the tuning box (a grid in rad/s
        serves a tunable T: the responses are periodic in ω with period 2π/T and symmetric
        about π/T, and the frequency metrics read nothing beyond π/T, see
        :mod:`feedtune.objectives.frequency.frequency_domain`). None: no frequency metric.
    """

    plant: IntegratorLag | Integrator
    gain: object
    period: object
    delay: int = 0
    drive: Drive = field(default_factory=Drive)
    horizon: float = 1.0
    period_min: float = 1e-3
    interpolator: Interpolator | None = None
    frequency_band: tuple | None = None
    discrete = True
    capabilities = frozenset({Capability.LINEAR, Capability.FREQUENCY_RESPONSE,
                              Capability.OPEN_LOOP, Capability.VELOCITY_CONSTANT,
                              Capability.EXACT_STEP_ERROR, Capability.SAMPLE_HORIZON,
                              Capability.HELD_COMMAND})

    @property
    def order(self) -> int:
        """States: the plant's and one per sample of delay (no matrix is built)."""
        return self.plant.order + self.delay

    @property
    def velocity_constant(self):
        """C_v = K [1/s]: the open loop K·ZOH·1/(s(1+sτ)) (or K·ZOH/s) is type 1 with gain K."""
        return self.gain

    @cached_property
    def _matrices(self):
        phi_p, gamma_p = self.plant.discretise(self.period)
        k = self.gain
        m = self.plant.order
        n = m + self.delay
        phi = ca.MX.zeros(n, n)
        gamma = ca.MX.zeros(n, 1)
        # feedback u = kx·state + kr·r applied over the coming period
        if self.delay == 0:
            kx = ca.horzcat(-k, ca.DM.zeros(1, m - 1))
            kr = k
        else:
            kx = ca.horzcat(ca.DM.zeros(1, n - 1), 1)
            kr = 0
        plant_rows = ca.horzcat(phi_p, ca.DM.zeros(m, self.delay)) + ca.mtimes(gamma_p, kx)
        phi[0:m, :] = plant_rows
        gamma[0:m, 0] = gamma_p * kr
        if self.delay > 0:
            phi[m, 0] = -k  # c(n) = K (r − x(n))
            gamma[m, 0] = k
            for i in range(1, self.delay):
                phi[m + i, m + i - 1] = 1
        return phi, gamma, kx, kr

    @property
    def position_row(self):
        return ca.horzcat(1, ca.DM.zeros(1, self.order - 1))

    @property
    def hold_input(self):
        """(k_x, k_r): the command held over the coming period is k_x·state + k_r·r."""
        return self._matrices[2], self._matrices[3]

    @at_shared_omega
    def frequency_response(self, omega):
        """Re and Im of position/reference at the samples, z = e^{jωT}, ω [rad/s]:
        H = N/(D + N) of the pulse transfer L = N/D (:attr:`pulse_transfer`)."""
        numerator, denominator = self.pulse_transfer
        return _ratio_on_circle(numerator, linalg.poly_add(denominator, numerator),
                                omega * self.period)

    @cached_property
    def pulse_transfer(self) -> tuple[list, list]:
        """(numerator, denominator) in z, highest power first, of the open loop
        L(z) = K·z^{−d}·P(z), P(z) = C(zI − Φ_p)⁻¹Γ_p the ZOH-discretised drive (Koren
        eqs 12–14): P = Γ/(z − Φ) for 1/s; for 1/(s(1 + sτ)) with Φ_p = [[1, a], [0, x]],
        P = (γ₀(z − x) + a·γ₁)/((z − 1)(z − x)), a = τ(1 − x), x = e^{−T/τ}.
        """
        phi, gamma = self.plant.discretise(self.period)
        k = self.gain
        if self.plant.order == 1:
            numerator, denominator = [k * gamma[0]], [1, -phi[0, 0]]
        else:
            x, a = phi[1, 1], phi[0, 1]
            numerator = [k * gamma[0], k * (a * gamma[1] - x * gamma[0])]
            denominator = linalg.poly_mul([1, -phi[0, 0]], [1, -x])
        return numerator, denominator + [0] * self.delay  # z^d·den: the delay

    @at_shared_omega
    def open_loop_response(self, omega):
        """Re and Im of L(e^{jωT}) = K·e^{−jdωT}·P(e^{jωT}), ω [rad/s]: exact, hold and
        computation delay included, periodic in ω with period 2π/T."""
        return _ratio_on_circle(*self.pulse_transfer, omega * self.period)

    def dc_gain(self):
        """H(z = 1) = N(1)/(D(1) + N(1)) [1]: 1 for this type-1 loop (D(1) = 0), kept as an
        expression for the normalisation |H/H(1)|."""
        numerator, denominator = self.pulse_transfer
        return sum(numerator) / (sum(denominator) + sum(numerator))

    def numeric_hold(self):
        """(Φ, Γ, k_x, k_r, T, τ) as numpy floats, for time responses evaluated on a loop of
        numbers (:func:`feedtune.loops.timeresponse.sampled_step_error`); τ None for the ideal
        drive 1/s.

        Raises
        ------
        TypeError
            For a loop of symbols (inside the NLP): these responses are reported only.
        """
        tau = self.plant.time_constant
        numbers = self._hold_numbers
        if numbers is None:
            raise TypeError("the sampled step response is evaluated on a loop of numbers "
                            "only (reported on the tuned design, never in the NLP)")
        arrays = [np.array(v, dtype=float) for v in numbers]
        phi, gamma, kx, kr, period = arrays[:5]
        return (phi, gamma.ravel(), kx.ravel(), float(kr.item()), float(period.item()),
                float(arrays[5].item()) if tau is not None else None)

    @cached_property
    def _hold_numbers(self) -> list | None:
        """[Φ, Γ, k_x, k_r, T] and τ (a drive with a time constant) as DM, all evaluated in
        one Function once per loop (issue 15: the characteristic polynomial, the held
        command's response and the step integrals each evaluated Φ); None for a loop of
        symbols."""
        return replayed_numbers(self, "hold", _hold_values) or _numbers(_hold_values(self))

    @cached_property
    def _state_numbers(self):
        """Φ_cl as a DM, from :attr:`_hold_numbers` (None for a loop of symbols)."""
        numbers = self._hold_numbers
        return None if numbers is None else numbers[0]

    @at_shared_omega
    def error_response(self, omega):
        """Re and Im of S = 1 − H at z = e^{jωT}, without the cancellation of 1 − H at low ω.

        With (I − Φ)⁻¹Γ the settled state, S(z) = (z − 1)·C(zI − Φ)⁻¹(I − Φ)⁻¹Γ, and
        z − 1 = −2 sin²(ωT/2) + j sin ωT.
        """
        n = self.order
        wt = omega * self.period
        re, im = linalg.complex_solve(ca.cos(wt) * ca.DM.eye(n) - self.state_matrix,
                                      ca.sin(wt) * ca.DM.eye(n), self._settled_state)
        d_re, d_im = -2 * ca.sin(wt / 2) ** 2, ca.sin(wt)
        return d_re * re[0] - d_im * im[0], d_re * im[0] + d_im * re[0]

    @cached_property
    def _settled_state(self):
        """(I − Φ)⁻¹Γ [m per m of reference]: the state a unit step settles to, built once per
        loop (every response of S and every radius error reads the same expression)."""
        return linalg.solve(ca.DM.eye(self.order) - self.state_matrix, self.input_matrix)

    @property
    def has_exact_step_error(self) -> bool:
        """The intersample error is integrated for a drive with a time constant only."""
        return self.plant.time_constant is not None

    @cached_property
    def step_error_integrals(self) -> StepIntegrals:
        """IAE/ISE/ITAE after a 1 m position step, intersample included.

        Each integral is summed sample by sample over ``horizon_samples`` with a CasADi fold
        of its own (:func:`_sample_step`), built when a metric first reads it: an IAE term
        carries no ISE or ITAE in its graph. Inside each sample the error is
        α + βs + γe^{−s}, s = σ/τ, integrated in closed form. The rest, from the horizon to
        infinity, is summed in closed form too (:func:`_tail`): exact for ISE, and exact for
        IAE and ITAE once the error no longer changes sign. A loop of numbers is summed on
        numbers (no graph is built).
        """
        radius = self._numeric_spectral_radius
        if radius is not None and radius >= 1:
            return StepIntegrals(lambda name: math.inf)  # unstable: never settles
        samples = self.horizon_samples  # raises HorizonError before any metric is built
        n = self.order
        if radius is not None:  # numbers: the small matrices evaluated once, as flat arrays
            numbers = [v.full().ravel(order="F") for v in self._hold_numbers]
            chunks = _binary_chunks(samples)
            # a fold of k samples reads each input k times over: the first k of these
            repeated = [np.tile(v, chunks[0]) for v in numbers]

            names = StepIntegrals._NAMES
            summed = {}

            def integral(name):  # the same samples in the same order, by folds of 2^k
                if not summed:  # samples, through their buffers (issue 15); all three
                    final = np.zeros(n + len(names) + 1)  # in one pass, at the first read
                    for k in chunks:
                        (final,) = _buffered(_sample_fold(n, names, k))(
                            final, *(r[:v.size * k] for r, v in zip(repeated, numbers)))
                    phi_, gamma_, kx_, _, period_, tau_ = numbers
                    tails = _buffered(_tail(n, names))(final[:n], final[n + len(names):],
                                                       phi_, gamma_, kx_, period_, tau_)
                    for i, (one, tail) in enumerate(zip(names, tails)):
                        tail = float(tail[0])
                        summed[one] = ca.DM(float(final[n + i])
                                            + (tail if one == "ise" else abs(tail)))
                return summed[name]

            return StepIntegrals(integral)

        phi, gamma_cl, kx, kr = self._matrices
        period, tau = self.period, self.plant.time_constant

        def integral(name):  # symbols: one fold of the whole horizon in the graph
            final = _sample_fold(n, name, samples)(ca.DM.zeros(n + 2), phi, gamma_cl, kx,
                                                    kr, period, tau)
            tail = _tail(n, name)(final[:n], final[n + 1], phi, gamma_cl, kx, period, tau)
            return final[n] + (tail if name == "ise" else ca.fabs(tail))

        return StepIntegrals(integral)


ContinuousLoop.embedded_fields = ("frequency_band",)
SampledLoop.embedded_fields = ("horizon", "period_min", "frequency_band")
for _loop in (ContinuousLoop, SampledLoop):  # see EmbeddedNumber
    for _name in _loop.embedded_fields:
        setattr(_loop, _name, EmbeddedNumber(_name))


@dataclass(frozen=True, eq=False)
class TransferLoop(_LoopBase):
    """Continuous position loop given by polynomials in s (highest power first).

    A cascade of transfer functions (inner velocity loop, outer position loop, series
    compensators) is closed by the plant into polynomials, so the characteristic polynomial
    is exact and a frequency response costs one Horner evaluation per frequency.

    Attributes
    ----------
    open_numerator, open_denominator
        Open loop L(s) = position / position error, type 1 (``open_denominator`` has the
        factor s).
    load_numerator
        Position per load torque [rad/(N·m)] over the closed-loop characteristic
        polynomial, or None when the plant has no load input.
    inner_characteristic
        Characteristic polynomial of an inner loop that must be stable on its own
        (Bhatia 1971, Ch. IV), or None.
    loop_gain_product
        Bhatia's sensitivity |G K'_v K'_p| [1/s] (Ch. IV eq 1), or None.
    frequency_band
        (low, high) [rad/s] containing every corner of the loop for any tunable in its box.
    drive : Drive
    interpolator : Interpolator or None
    """

    open_numerator: list
    open_denominator: list
    load_numerator: list | None = None
    inner_characteristic: list | None = None
    loop_gain_product: object = None
    frequency_band: tuple = (1e-2, 1e5)
    drive: Drive = field(default_factory=Drive)
    interpolator: Interpolator | None = None
    discrete = False
    period = None
    capabilities = frozenset({Capability.LINEAR, Capability.FREQUENCY_RESPONSE,
                              Capability.OPEN_LOOP, Capability.VELOCITY_CONSTANT,
                              Capability.NUMERIC_TRANSFER, Capability.LOAD_INPUT,
                              Capability.LOOP_GAIN_PRODUCT})

    @cached_property
    def closed_denominator(self) -> list:
        """den L + num L: the closed loop's characteristic polynomial (not monic)."""
        return linalg.poly_add(self.open_denominator, self.open_numerator)

    @cached_property
    def characteristic_polynomial(self) -> list:
        lead = self.closed_denominator[0]
        return [c / lead for c in self.closed_denominator]

    @property
    def order(self) -> int:
        """Degree of the characteristic polynomial (no matrix is built)."""
        return len(self.closed_denominator) - 1

    @cached_property
    def state_matrix(self):
        """Companion matrix of the closed loop (its eigenvalues are the closed-loop poles)."""
        return linalg.companion_matrix(self.closed_denominator)

    @property
    def velocity_constant(self):
        """C_v = lim s·L(s) [1/s] (type-1 open loop)."""
        reduced = self.open_denominator[:-1]  # den / s
        return self.open_numerator[-1] / reduced[-1]

    def stability_matrices(self) -> dict:
        matrices = {"closed_loop": self.state_matrix}
        if self.inner_characteristic is not None:
            matrices["inner_loop"] = linalg.companion_matrix(self.inner_characteristic)
        return matrices

    def stability_conditions(self) -> list:
        """Hurwitz conditions of the closed loop, and of the inner loop where it must be stable."""
        conditions = linalg.hurwitz_conditions(linalg.balanced_polynomial(self.closed_denominator))
        if self.inner_characteristic is not None:
            conditions += linalg.hurwitz_conditions(
                linalg.balanced_polynomial(self.inner_characteristic))
        return conditions

    @staticmethod
    def _ratio(numerator, denominator, omega):
        n_re, n_im = linalg.poly_at_jw(numerator, omega)
        d_re, d_im = linalg.poly_at_jw(denominator, omega)
        d2 = d_re**2 + d_im**2
        return (n_re * d_re + n_im * d_im) / d2, (n_im * d_re - n_re * d_im) / d2

    @at_shared_omega
    def open_loop_response(self, omega):
        """Re and Im of L(jω), ω [rad/s]."""
        return self._ratio(self.open_numerator, self.open_denominator, omega)

    @at_shared_omega
    def frequency_response(self, omega):
        """Re and Im of position/reference T = L/(1 + L) at s = jω, ω [rad/s]."""
        return self._ratio(self.open_numerator, self.closed_denominator, omega)

    @at_shared_omega
    def error_response(self, omega):
        """Re and Im of S = 1 − T = den L/(den L + num L): exact at low ω."""
        return self._ratio(self.open_denominator, self.closed_denominator, omega)

    def dc_gain(self):
        """T(0) [1]: 1 for a type-1 loop, kept as an expression for normalisation."""
        return self.open_numerator[-1] / self.closed_denominator[-1]

    has_exact_step_error = False

    def numeric_transfer(self, output: str = "position", input: str = "reference"):
        """(numerator, denominator) as float arrays of a response, highest power first.

        ``input`` is ``reference`` [rad] or ``load`` [N·m]; ``output`` is ``position``
        [rad] or ``error`` [rad] (reference − position). For loops of numbers only.
        """
        def floats(p):
            return np.array([to_float(c) for c in p])

        den = floats(self.closed_denominator)
        if input == "reference":
            num = floats(self.open_numerator if output == "position" else self.open_denominator)
        elif input == "load":
            if self.load_numerator is None:
                raise ValueError("this loop has no load input")
            num = floats(self.load_numerator)
            num = num if output == "position" else -num
        else:
            raise ValueError(f"unknown input {input!r}")
        return num, den
