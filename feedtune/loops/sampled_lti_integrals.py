"""Exact step-error integrals of :class:`feedtune.loops.sampled_lti.SampledLTILoop`,
intersample included.

Inside one period the plant runs open loop under a held command, so with
ξ = [x, u, r] the error e = r − C x obeys ξ' = F ξ, F = [[A, B, 0], [0, 0, 0], [0, 0, 0]].
Each held segment (two when a fractional dead time splits the period) is cut into M equal
sub-steps with ‖Ã‖₁·T_max/M ≤ 1, Ã = D⁻¹AD balanced
(:func:`feedtune.loops.sampled_plants.balance`). On a sub-step, e(σ) is the Taylor polynomial
Σ_{k≤18} (σ/h)^k · ρ_k, ρ_k = [−C 0 1]·(F h)^k ξ/k!, h = T_max/M, whose remainder is below
e/19! ≈ 2e-17 of the state's scale (‖(F h)^k‖ ≤ 1): the error *is* this polynomial to
rounding. Its integrals are then exact: ∫e², and ∫|e| and ∫t|e| on pieces cut at the
stationary point of e and at its zeros (safeguarded Newton inside each bracket), as
:func:`feedtune.loops.signals.sample_error_integrals` does for Koren's drive.

Assumption (as Koren's α + βs + γe^{−s}, where it holds exactly): e' has at most one zero
per sub-step. A sub-step spans at most 1/(2π) of the period of the fastest mode (‖A‖h ≤ 1);
a second zero of e' there would be a tangency of e with 0, whose missed sliver is
third order in its width.

After ``samples`` samples the rest is summed as :func:`feedtune.loops.loop._tail` does, from
per-sample moments linear (∫e, ∫t·e) and quadratic (∫e²) in the distance to the settled
state: exact for ISE, and for IAE/ITAE once e no longer changes sign (the tuner's settling
conditions keep that honest). The geometric sums Σ Φ^k, Σ kΦ^k and Σ (Φ^k)ᵀQΦ^k are summed
by doubling rather than by solving (I − Φᵀ⊗Φᵀ) vec P = vec Q: a drive's states mix units,
and that system's condition number reached 1e12 on the two-mass test drive, where CasADi's
symbolic solve lost four digits.
"""

from __future__ import annotations

import math
from functools import lru_cache

from feedtune.lazy import ca, np
from feedtune.loops import linalg

#: Taylor degree of the intersample error polynomial (see the module docstring)
DEGREE = 18
#: safeguarded Newton iterations per root on the polynomial truncated to COARSE_DEGREE
#: (its terms beyond are below 1/9! ≈ 3e-6 of the state's scale, ‖Ãh‖ ≤ 1) …
NEWTON_STEPS = 5
COARSE_DEGREE = 8
#: … then Newton steps on the full polynomial: quadratic convergence from ~3e-6 of a
#: sub-step; a zero's misplacement changes ∫|e| only to second order (e vanishes there)
FINAL_STEPS = 2
_TINY = 1e-300


def _horner(coefficients, x):
    result = 0
    for c in reversed(coefficients):
        result = result * x + c
    return result


def _root(coefficients, lo, hi, f_lo, f_hi, guess=None):
    """The zero of the polynomial in [lo, hi] where it changes sign once (f_lo·f_hi < 0).

    Starts from the secant or from ``guess``, whichever has the smaller |f|, then Newton
    steps kept inside a shrinking bracket (bisection when a step leaves it): NEWTON_STEPS
    on the truncated polynomial, FINAL_STEPS on the full one.
    """
    gap = f_hi - f_lo
    s = lo - f_lo * (hi - lo) / ca.if_else(gap == 0, 1, gap)
    s = ca.fmin(ca.fmax(s, lo), hi)
    if guess is not None:
        guess = ca.fmin(ca.fmax(guess, lo), hi)
        closer = ca.fabs(_horner(coefficients, guess)) < ca.fabs(_horner(coefficients, s))
        s = ca.if_else(closer, guess, s)
    coarse = coefficients[:COARSE_DEGREE + 1]
    for polynomial in [coarse] * NEWTON_STEPS + [coefficients] * FINAL_STEPS:
        derivative = [k * c for k, c in enumerate(polynomial)][1:]
        f = _horner(polynomial, s)
        df = _horner(derivative, s)
        same = f * f_lo > 0
        lo, f_lo, hi = ca.if_else(same, s, lo), ca.if_else(same, f, f_lo), ca.if_else(same, hi, s)
        step = s - f / ca.if_else(ca.fabs(df) < _TINY, _TINY, df)
        # ≤, not <: at an exact zero (f = 0) the step stays at s = hi, and must be kept
        s = ca.if_else((step >= lo) * (step <= hi), step, (lo + hi) / 2)
    return s


def _substep(coefficients, end, scale, t_start, name):
    """The integral ``name`` over one sub-step of e(h·x) = Σ c_k x^k, 0 ≤ x ≤ ``end``.

    ``scale`` is h [s], ``t_start`` the sub-step's start time [s]. iae and itae are cut at
    the stationary point and the zeros; ise integrates the squared polynomial; signed gives
    [∫e dt, ∫t·e dt] without absolute values (linear in the state, for the tail).
    """
    area_coefficients = [c / (k + 1) for k, c in enumerate(coefficients)]
    moment_coefficients = [c / (k + 2) for k, c in enumerate(coefficients)]

    def primitives(x):  # ∫₀ˣ e dσ/h and ∫₀ˣ (σ/h) e dσ/h, by Horner
        return (x * _horner(area_coefficients, x), x**2 * _horner(moment_coefficients, x))

    if name == "signed":
        area, moment = primitives(end)
        return ca.vertcat(scale * area, t_start * scale * area + scale**2 * moment)
    if name == "ise":
        square = [0] * (2 * len(coefficients) - 1)
        for i, a in enumerate(coefficients):
            for j, b in enumerate(coefficients):
                square[i + j] = square[i + j] + a * b
        return scale * end * _horner([c / (k + 1) for k, c in enumerate(square)], end)
    slope = [k * c for k, c in enumerate(coefficients)][1:]
    d0, d_end = _horner(slope, 0), _horner(slope, end)
    middle = ca.if_else(d0 * d_end < 0, _root(slope, 0, end, d0, d_end), end)
    f0, fm, fe = coefficients[0], _horner(coefficients, middle), _horner(coefficients, end)
    # beside a near-double zero Newton starts badly from the secant: the quadratic model at
    # the stationary point, e(m) + e''(m)(x − m)²/2 = 0, gives the zeros on either side
    # (Koren's _newton_start does the same)
    curvature = _horner([k * c for k, c in enumerate(slope)][1:], middle)
    offset = ca.sqrt(ca.fmax(-2 * fm / ca.if_else(curvature == 0, 1, curvature), _TINY))
    zero1 = ca.if_else(f0 * fm < 0, _root(coefficients, 0, middle, f0, fm, middle - offset),
                       middle)
    zero2 = ca.if_else(fm * fe < 0, _root(coefficients, middle, end, fm, fe, middle + offset),
                       end)

    cuts = [primitives(x) for x in (0, zero1, middle, zero2, end)]
    total = 0
    for (f_a, g_a), (f_b, g_b) in zip(cuts[:-1], cuts[1:]):
        if name == "iae":
            total += ca.fabs(f_b - f_a)
        else:
            total += ca.fabs(t_start * (f_b - f_a) + scale * (g_b - g_a))
    return scale * total


@lru_cache(maxsize=None)
def _substep_function(name: str):
    """:func:`_substep` of generic coefficients, end, scale and start time, as an SX
    Function. Called on SX arguments, it writes the same operations into the caller's graph
    (constants folded by the same double operations) in C++, where building them in Python
    again for every sub-step of every sample cost ≈ 1.7 s of CPU per integral Function on
    a long period box (``benchmarks/README.md``, issue 15)."""
    coefficients = ca.SX.sym("c", DEGREE + 1)
    end, scale, t_start = ca.SX.sym("end"), ca.SX.sym("scale"), ca.SX.sym("t_start")
    value = _substep([coefficients[k] for k in range(DEGREE + 1)], end, scale, t_start, name)
    return ca.Function(f"lti_substep_{name}", [coefficients, end, scale, t_start], [value])


class _Structure:
    """The numbers of one loop's intersample integration: the rows giving the error's and the
    state's Taylor coefficients from ξ (from F's scaled powers), the sub-steps per segment."""

    def __init__(self, a, b, c, t_max):
        from feedtune.loops.sampled_plants import balance

        self.n = a.shape[0]
        n = self.n
        a, scaling = balance(a)  # x = D x̃: the Taylor bound on the balanced ‖D⁻¹AD‖₁
        self.scaling = ca.DM(scaling)
        self.substeps = max(1, math.ceil(float(np.linalg.norm(a, 1)) * t_max))
        self.h = t_max / self.substeps  # the longest sub-step [s]
        f = np.zeros((n + 2, n + 2))
        f[:n, :n], f[:n, n:n + 1] = a, np.reshape(b, (n, 1)) / scaling[:, None]
        powers = [np.eye(n + 2)]
        for k in range(1, DEGREE + 1):
            powers.append(powers[-1] @ f * self.h / k)  # (F h)^k/k!
        error_row = np.concatenate([-np.ravel(c) * scaling, [0.0, 1.0]])
        # e's coefficients on ξ, row k giving ρ_k: one product per sub-step (same bits)
        self.error_rows = ca.DM(np.array([error_row @ p for p in powers]))
        self.state_rows = [ca.DM(p[:n, :]) for p in powers]  # x̃'s coefficients on ξ

    def sample(self, z, reference, segments, t_start, name):
        """∫ over one period, starting at state ``z``; segments [(length, K, k)]."""
        n = self.n
        x = z[:n] / self.scaling  # balanced coordinates x̃
        total, t = 0, t_start
        for length, gain_row, gain_ref in segments:
            u = ca.mtimes(gain_row, z) + gain_ref * reference
            end = length / self.substeps / self.h  # sub-step length in units of h (≤ 1)
            transition = _horner(self.state_rows, end)  # ξ at the start → x̃ at the end
            for _ in range(self.substeps):
                xi = ca.vertcat(x, u, reference)
                coefficients = ca.mtimes(self.error_rows, xi)
                total += _substep_function(name)(coefficients, end, self.h, t)
                x = ca.mtimes(transition, xi)
                t = t + end * self.h
        return total


@lru_cache(maxsize=32)
def _structure(a_bytes, b_bytes, c_bytes, n: int, t_max: float) -> _Structure:
    """:class:`_Structure` of a plant (A, B, C as bytes, order ``n``) for periods up to
    ``t_max`` [s], shared by the step and tail Functions of its integrals."""
    a = np.frombuffer(a_bytes).reshape(n, n)
    b = np.frombuffer(b_bytes).reshape(n, 1)
    c = np.frombuffer(c_bytes).reshape(1, n)
    return _Structure(a, b, c, t_max)


def _symbols(order: int, n_segments: int):
    """The Functions' loop arguments as SX symbols: (z, Φ, Γ, segments, T, args)."""
    N = order
    phi, gamma = ca.SX.sym("phi", N, N), ca.SX.sym("gamma", N)
    lengths = [ca.SX.sym(f"h{i}") for i in range(n_segments)]
    rows = [ca.SX.sym(f"K{i}", 1, N) for i in range(n_segments)]
    refs = [ca.SX.sym(f"k{i}") for i in range(n_segments)]
    period = ca.SX.sym("period")
    args = [phi, gamma, *lengths, *rows, *refs, period]
    return phi, gamma, list(zip(lengths, rows, refs)), period, args


@lru_cache(maxsize=32)
def _step_function(plant_key, order: int, n_segments: int, name: str):
    """The per-sample step Function of one loop structure: [z, ∫, t] one sample later. It
    does not depend on the number of samples summed, so loops of numbers with different
    horizons share it."""
    structure = _structure(*plant_key)
    N = order
    _, _, segments, period, args = _symbols(order, n_segments)
    phi, gamma = args[0], args[1]
    state = ca.SX.sym("state", N + 2)
    z = state[:N]
    piece = structure.sample(z, 1, segments, state[N + 1], name)
    nxt = ca.vertcat(ca.mtimes(phi, z) + gamma, state[N] + piece, state[N + 1] + period)
    return ca.Function(f"lti_sample_{name}", [state, *args], [nxt])


@lru_cache(maxsize=32)
def _tail_function(plant_key, order: int, n_segments: int, name: str, doublings: int):
    """The closed-form tail Function of one loop structure, summing 2^``doublings`` terms."""
    structure = _structure(*plant_key)
    N = order
    phi, gamma, segments, period, args = _symbols(order, n_segments)
    # per-sample signed moments of the deviation δ from the settled state (r = 0)
    delta = ca.SX.sym("delta", N)
    first = structure.sample(delta, 0, segments, 0, "signed")
    c1 = ca.jacobian(first[0], delta)
    c2 = ca.jacobian(first[1], delta)
    q = ca.hessian(structure.sample(delta, 0, segments, 0, "ise"), delta)[0] / 2
    q = ca.substitute(q, delta, ca.DM.zeros(N))  # quadratic form: its Hessian is constant
    c1 = ca.substitute(c1, delta, ca.DM.zeros(N))
    c2 = ca.substitute(c2, delta, ca.DM.zeros(N))
    z_end, t_end = ca.SX.sym("z_end", N), ca.SX.sym("t_end")
    deviation = z_end - linalg.pivoted_solve(ca.DM.eye(N) - phi, gamma)  # QR lost cond² digits
    power = phi  # Φ^(2^j)
    geometric = ca.SX.eye(N)  # Σ_{k<2^j} Φ^k
    weighted = ca.SX.zeros(N, N)  # Σ_{k<2^j} k Φ^k
    gramian = q  # Σ_{k<2^j} (Φ^k)ᵀ Q Φ^k
    for j in range(doublings):
        if name == "ise":
            gramian = gramian + ca.mtimes([power.T, gramian, power])
        else:
            weighted = weighted + ca.mtimes(power, weighted) + 2**j * ca.mtimes(power, geometric)
            geometric = geometric + ca.mtimes(power, geometric)
        power = ca.mtimes(power, power)
    sum_e = ca.mtimes([c1, geometric, deviation])
    if name == "ise":
        tail = ca.mtimes([deviation.T, gramian, deviation])
    elif name == "iae":
        tail = sum_e
    else:
        tail = (t_end * sum_e + period * ca.mtimes([c1, weighted, deviation])
                + ca.mtimes([c2, geometric, deviation]))
    return ca.Function(f"lti_tail_{name}", [z_end, t_end, *args], [tail])


def _functions(key, name: str):
    """(step, tail) Functions of one loop structure (``key`` from :func:`_key`)."""
    a_bytes, b_bytes, c_bytes, n, order, n_segments, t_max, samples = key
    plant_key = (a_bytes, b_bytes, c_bytes, n, t_max)
    # the tail sums 2^doublings ≥ 16·samples terms: the settling conditions bound the
    # spectral radius by SETTLE_FRACTION^(1/samples), so the terms left are below 1e-64
    doublings = max(1, math.ceil(math.log2(16 * samples)))
    return (_step_function(plant_key, order, n_segments, name),
            _tail_function(plant_key, order, n_segments, name, doublings))


def _key(loop, samples: int, numeric: bool = False) -> tuple:
    """The structure of ``loop``'s integrals: plant, orders, segments, the longest period
    its sub-steps are sized for, ``samples``.

    Symbols: the period box's upper bound T_max (any period of the box). Numbers: the
    loop's own period T rounded up to a power of two (at most T_max), so the sub-steps are
    sized for T within a factor 2 (a long period box cut a 2.2 ms period into 52 sub-steps
    instead of one) while loops of nearby periods still share their Functions."""
    plant = loop.plant
    t_max = float(loop.period_box[1])
    if numeric:
        t_max = min(t_max, 2.0 ** math.ceil(math.log2(float(ca.evalf(ca.MX(loop.period))))))
    return (np.ascontiguousarray(plant.a, dtype=float).tobytes(),
            np.ascontiguousarray(plant.b, dtype=float).tobytes(),
            np.ascontiguousarray(plant.c, dtype=float).tobytes(),
            plant.order, loop.order, len(loop.segments()), t_max, samples)


def _arguments(loop, numeric: bool) -> list:
    args = [loop.state_matrix, loop.input_matrix]
    segments = loop.segments()
    args += [length for length, _, _ in segments] + [row for _, row, _ in segments]
    args += [ref for _, _, ref in segments] + [loop.period]
    if numeric:  # numbers: evaluate the small matrices once, sum on DM
        args = [ca.evalf(ca.MX(arg)) for arg in args]
    return args


def step_integral(loop, name: str, samples: int, numeric: bool):
    """IAE, ISE or ITAE (``name``) of ``loop``'s error after a unit step: ``samples``
    samples folded one by one, then the closed-form tail."""
    step, tail = _functions(_key(loop, samples, numeric), name)
    args = _arguments(loop, numeric)
    n = loop.order
    final = step.fold(samples)(ca.DM.zeros(n + 2), *args)
    rest = tail(final[:n], final[n + 1], *args)
    return final[n] + (rest if name == "ise" else ca.fabs(rest))


def partial_integral(loop, name: str, samples: int) -> float:
    """IAE, ISE or ITAE over the first ``samples`` samples only, for a loop of numbers
    (no tail; what the fold sums)."""
    step, _ = _functions(_key(loop, samples, True), name)
    n = loop.order
    final = step.fold(samples)(ca.DM.zeros(n + 2), *_arguments(loop, True))
    return float(final[n])
