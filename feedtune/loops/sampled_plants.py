"""Plants of the general sampled-data loop and their exact zero-order-hold discretisation.

:class:`ContinuousPlant` (numeric state space, input dead time) and :class:`DiscretePlant`
(a discrete model with its own period); :func:`expm_function` gives e^{Mt} as a CasADi
expression of a tunable t, so the sampling period may be a decision variable.

References
----------
Franklin, Powell & Workman, *Digital Control of Dynamic Systems*, ch. 4 (ZOH models,
fractional input delay); Higham, *Functions of Matrices*, ch. 10 (scaling and squaring).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property, lru_cache

from feedtune.lazy import ca, np
from feedtune.loops.errors import SampledModelError

#: Taylor degree of the exponential's core; with the scaled argument's 1-norm ≤ 1 the
#: truncation is ≤ e/19! ≈ 2e-17 of the norm, below double rounding (1.1e-16)
TAYLOR_DEGREE = 18
#: θ/T within this (relative) of a whole number counts as that number: the rounding of θ/T
#: when θ is an exact multiple of T (a few ulps; 1e-12 leaves room for θ computed as q·T)
WHOLE_SAMPLE_TOL = 1e-12


def _float_matrix(value, name: str, shape=None) -> np.ndarray:
    array = np.atleast_2d(np.asarray(value, dtype=float))
    if not np.all(np.isfinite(array)):
        raise SampledModelError(f"{name}: not finite")
    if shape is not None and array.shape != shape:
        raise SampledModelError(f"{name}: shape {array.shape}, expected {shape}")
    return array


def _state_space(a, b, c, d) -> tuple:
    """(A, B, C, D) as float arrays of a SISO model with a position output: A square n×n,
    B n×1, C 1×n, D 1×1 and 0; a bad one is a SampledModelError naming its field."""
    a = _float_matrix(a, "/plant/a")
    n = a.shape[0]
    if a.shape != (n, n) or n == 0:
        raise SampledModelError(f"/plant/a: shape {a.shape}, expected square n×n, n ≥ 1")
    b = _float_matrix(np.reshape(b, (-1, 1)) if np.size(b) == n else b, "/plant/b", (n, 1))
    c = _float_matrix(c, "/plant/c", (1, n))
    d = _float_matrix(d, "/plant/d", (1, 1))
    if d[0, 0] != 0:
        raise SampledModelError("/plant/d: must be 0 (the position output has no direct "
                                "feedthrough of the drive's input)")
    return a, b, c, d


def balance(matrix) -> tuple:
    """(D⁻¹MD, d): a diagonal similarity by powers of two (exact in floating point) that
    equalises row and column norms (scipy.linalg.matrix_balance, no permutation). A drive's
    states mix units (rad, rad/s, A): ‖A‖₁ = 3e5 of a two-mass drive whose fastest mode is
    548 rad/s falls to 781."""
    from scipy.linalg import matrix_balance

    balanced, (scaling, _) = matrix_balance(np.asarray(matrix, dtype=float), permute=False,
                                            separate=True)
    return balanced, scaling


def expm_function(matrix, t_max: float, minus_identity: bool = False) -> ca.Function:
    """``t ↦ e^{M t}`` for 0 ≤ t ≤ ``t_max`` [s] as a CasADi Function (SX, differentiable);
    with ``minus_identity``, ``t ↦ e^{M t} − I`` without adding and removing I (the digits
    of a transition close to I that a sampled loop's Schur test of Φ − I lives in).

    Scaling and squaring with a Taylor core on the balanced M̃ = D⁻¹MD (:func:`balance`):
    s = ⌈log₂(‖M̃‖₁ t_max)⌉ squarings (fixed at build time from the largest t), so
    ‖M̃ t / 2^s‖₁ ≤ 1 for every t in the box, and the core Σ_{k≤18} (M̃ t/2^s)^k/k! is a
    matrix polynomial in the scalar t/t_max whose coefficient matrices are numbers computed
    once. Its truncation error is below e/19! ≈ 2e-17 of the norm. The squarings act on
    F = e^{M̃t/2^s} − I, (I + F)² − I = 2F + F², so a short t (T = 1e-4 s in a box up to
    0.1 s: seven squarings) keeps the digits of e^{Mt} − I that ∫e^{As}ds·B lives in; squaring
    e^{M̃t/2^s} itself lost them (2.8e-11 of a column against 9e-14 this way, measured
    against scipy.linalg.expm in tests/unit/test_sampled_lti.py). ``casadi.expm`` is not usable (its plugin is missing
    from the wheel, docs/design.md numerical notes).
    """
    matrix = np.ascontiguousarray(matrix, dtype=float)
    return _expm_function(matrix.tobytes(), matrix.shape[0], float(t_max), minus_identity)


@lru_cache(maxsize=256)
def _expm_function(matrix_bytes: bytes, n: int, t_max: float,
                   minus_identity: bool) -> ca.Function:
    """:func:`expm_function` of M given by its bytes (n×n), built once per process for every
    loop of the same plant and period box: a loop of numbers built per point (a robust
    search, a batch, the plant contract's grid) built it again each time, ≈ 4 ms."""
    matrix = np.frombuffer(matrix_bytes).reshape(n, n)
    m, scaling = balance(matrix)
    norm = float(np.linalg.norm(m, 1)) * t_max
    squarings = max(0, math.ceil(math.log2(norm))) if norm > 0 else 0
    scaled = m * t_max / 2**squarings
    coefficients = [np.eye(n)]
    for k in range(1, TAYLOR_DEGREE + 1):
        coefficients.append(coefficients[-1] @ scaled / k)
    t = ca.SX.sym("t")
    x = t / t_max
    # F = e^{M̃t/2^s} − I: Horner in the scalar x, entry by entry, without the identity
    f = ca.SX(ca.DM(coefficients[-1]))
    for c in reversed(coefficients[1:-1]):
        f = f * x + ca.DM(c)
    f = f * x
    for _ in range(squarings):  # (I + F)² − I = 2F + F²: small t keeps its digits
        f = 2 * f + ca.mtimes(f, f)
    result = f if minus_identity else ca.DM.eye(n) + f
    # the balancing scalings are powers of two: undoing them is exact
    undo = ca.mtimes([ca.DM(np.diag(scaling)), result, ca.DM(np.diag(1 / scaling))])
    return ca.Function("expm", [t], [undo])


def split_dead_time(dead_time: float, dead_time_samples: float | None, period,
                    period_box: tuple[float, float]):
    """(d, θ_f): θ = d·T + θ_f, d whole, 0 ≤ θ_f ≤ T, θ_f an expression of T [s].

    With T a tunable, d must be the same over the whole box [T_min, T_max]:
    ⌊θ/T_max⌋ = d and θ/T_min ≤ d + 1; θ_f = θ − d·T is then smooth in T. A dead time
    given in samples (θ = q·T, ``dead_time_samples``) splits as d = ⌊q⌋, θ_f = (q − d)·T
    for any T. Pure arithmetic: a spec is checked without building the loop.

    Raises
    ------
    SampledModelError
        ``/plant/dead_time``: the whole number of samples changes over the box.
    """
    if dead_time_samples is not None:
        q = dead_time_samples
        whole = math.floor(q + WHOLE_SAMPLE_TOL)
        fraction = max(q - whole, 0.0)
        return whole, (fraction * period if fraction > 0 else 0)
    theta = dead_time
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


@dataclass(frozen=True, eq=False)
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
    #: a model in s, sampled by the loop's hold (DiscretePlant: True)
    discrete = False

    def __post_init__(self):
        a, b, c, d = _state_space(self.a, self.b, self.c, self.d)
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
        """(d, θ_f): θ = d·T + θ_f, d whole, 0 ≤ θ_f ≤ T, θ_f an expression of T [s]
        (:func:`split_dead_time`)."""
        return split_dead_time(self.dead_time, self.dead_time_samples, period, period_box)


@dataclass(frozen=True, eq=False)
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
    discrete = True

    def __post_init__(self):
        a, b, c, d = _state_space(self.a, self.b, self.c, self.d)
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
