"""A continuous closed loop of numbers for the validator: ẋ = A x + B [θ_i, T_L], θ = C x,
with its open loop L (the position feedback broken) as a second state-space system.

Frequency responses are C(jωI − A)⁻¹B on a dense grid, refined by Brent's method; time
responses are the exact state on a graded grid (scipy.linalg.expm of the augmented matrix,
so the input is exact too), extremes and band exits refined by Brent's method on the
exact state. Used by Bhatia's cascades (:mod:`feedtune.validate.cascade`) and Sato's Padé
model of the software servo.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm
from scipy.optimize import brentq, minimize_scalar

from feedtune.validate.integrals import error_integrals
from feedtune.validate.measurements import Measurement, Phase, measure_entries
from feedtune.validate.model import NotCovered, Response
from feedtune.validate.tolerances import Context

#: the response is simulated until the slowest mode has decayed to this fraction
SETTLED = 1e-12
#: grid step [s]: at most FINE/|p| of the fastest mode still above ALIVE (relative), growing
#: by at most GROWTH per step
FINE, GROWTH, ALIVE = 0.01, 1.02, 1e-10
#: frequency grid [points per decade] over FREQUENCY_SPAN beyond the slowest/fastest pole
POINTS_PER_DECADE, FREQUENCY_SPAN = 200, 1e3


@dataclass(frozen=True)
class Block:
    """ẋ = A x + B w, y = C x + D w."""

    a: np.ndarray
    b: np.ndarray
    c: np.ndarray
    d: np.ndarray

    @property
    def order(self) -> int:
        return self.a.shape[0]


def leading_zeros_trimmed(coefficients) -> np.ndarray:
    """``numpy.trim_zeros(c, "f")`` of a 1-d float array: the same values, without its
    n-dimensional search (≈ 15 µs a call, which a validator model's construction paid
    twelve times)."""
    c = np.atleast_1d(np.asarray(coefficients, dtype=float))
    nonzero = np.flatnonzero(c)
    return c[nonzero[0]:] if nonzero.size else c[:0]


def siso(numerator: list, denominator: list) -> Block:
    """A proper n(s)/d(s) (highest power first) in controllable canonical form."""
    num, den = leading_zeros_trimmed(numerator), leading_zeros_trimmed(denominator)
    num, den = num / den[0], den / den[0]
    n = len(den) - 1
    if len(num) > n + 1:
        raise ValueError("improper transfer function")
    num = np.concatenate([np.zeros(n + 1 - len(num)), num])
    d = num[0]
    rest = num[1:] - d * den[1:]  # strictly proper remainder, coefficients of s^(n−1)…s^0
    a = np.zeros((n, n))
    if n:
        a[0, :] = -den[1:]
        a[1:, :-1] = np.eye(n - 1)
    b = np.zeros((n, 1))
    if n:
        b[0, 0] = 1.0
    return Block(a, b, rest.reshape(1, n), np.array([[d]]))



def _run(t: float, h: float, limit: float) -> tuple[list[np.ndarray], float]:
    """The steps h taken from time t while t < limit (t advanced by t += h after each, as
    a step-by-step loop would: np.cumsum adds in the same order), as pieces of at most
    10 million steps to be concatenated once by the caller, and the time after them."""
    pieces = []
    while t < limit:
        count = int(min((limit - t) / h, 1e7)) + 2
        times = np.full(count + 1, h)
        times[0] = t
        np.cumsum(times, out=times)
        # times never decrease (h > 0): the first time ≥ limit by bisection
        taken = int(np.searchsorted(times, limit)) if times[-1] >= limit else count
        pieces.append(np.full(taken, h))
        t = float(times[taken])
    return pieces, t


def grid_times(steps: np.ndarray) -> np.ndarray:
    """The times [s] of the grid of ``steps``: 0, then each the sum of the steps before it
    (np.cumsum's order), written into one array (no second copy of a grid that may hold
    31 million points)."""
    t = np.empty(steps.size + 1)
    t[0] = 0.0
    np.cumsum(steps, out=t[1:])
    return t


#: a run of equal steps is propagated RUN_BLOCK states at a time (see :func:`_propagate`)
RUN_BLOCK = 128


def _propagate(m: np.ndarray, z0: np.ndarray, steps: np.ndarray,
               output: np.ndarray | None = None) -> np.ndarray:
    """The exact states z(t_i) of z' = M z, z(0) = z0 (a vector, or a matrix of initial
    states in its columns), on the grid of ``steps`` [s]: entry i is z after the first i
    steps, each step z ← e^{Mh} z (scipy's expm, once per distinct h). With ``output`` (a
    row c), entry i is c z(t_i) instead, and the states are not kept.

    The graded grid is mostly a few long runs of one step h (the fastest live mode's
    FINE/|p|; Bhatia's tuned loop: 34k of its 41k steps in one run). A run is propagated
    in blocks: with P_j = e^{Mhj} (j = 1 … RUN_BLOCK, each E·P_{j−1}), the next RUN_BLOCK
    states are P_j z at once, instead of one Python matrix-vector product per step (their
    outputs (c P_j) z: one row per step instead of a matrix, which matters where a lightly
    damped mode keeps the fine step for 31 million steps; there the block's first states
    are chained in Python and every block's outputs are one stacked product, each block's
    (c P_j) z the same matrix product as alone). A run shorter than
    2·RUN_BLOCK is the step-by-step product itself; a longer one differs from it only by
    rounding (≤ 4.3e-13 of the response's scale on the bundled Bhatia and Ward-Leonard
    results; tests/unit/test_validator_propagation.py).
    """
    n_steps = steps.size
    states = np.empty((n_steps + 1,) + (z0.shape if output is None else z0.shape[1:]))
    z = z0
    states[0] = z0 if output is None else output @ z0
    change = np.flatnonzero(steps[1:] != steps[:-1]) + 1
    starts = np.concatenate([[0], change]).astype(int)
    ends = np.concatenate([change, [n_steps]]).astype(int)
    transitions: dict[float, np.ndarray] = {}
    for start, end in zip(starts, ends):
        h = float(steps[start])
        step = transitions.get(h)
        if step is None:
            step = transitions[h] = expm(m * h)
        if end - start < 2 * RUN_BLOCK:
            for i in range(start, end):
                z = step @ z
                states[i + 1] = z if output is None else output @ z
            continue
        powers = np.empty((RUN_BLOCK,) + step.shape)
        powers[0] = step
        for j in range(1, RUN_BLOCK):
            powers[j] = step @ powers[j - 1]
        seen = powers if output is None else output @ powers
        i = start
        if output is not None:  # the whole blocks' outputs in one stacked product
            blocks = (end - start) // RUN_BLOCK
            firsts = np.empty((blocks,) + np.shape(z))
            for b in range(blocks):
                firsts[b] = z
                z = powers[-1] @ z
            outputs = states[start + 1:start + 1 + blocks * RUN_BLOCK]
            outputs = outputs.reshape((blocks, RUN_BLOCK) + outputs.shape[1:])
            if np.ndim(z) == 2:  # each block (c P_j) z as before: the same matrix product
                np.matmul(seen, firsts, out=outputs)
            else:
                np.matmul(seen, firsts[..., None], out=outputs[..., None])
            i = start + blocks * RUN_BLOCK
        while i < end:
            k = min(RUN_BLOCK, end - i)
            states[i + 1:i + 1 + k] = seen[:k] @ z
            z = states[i + k] if output is None else powers[k - 1] @ z
            i += k
    return states


class ContinuousModel:
    """Closed loop (a, b, c): inputs [θ_i, T_L] (b has two columns), output θ; open loop
    (open_a, open_b, open_c): input e_p, output θ."""

    sampled = False
    period = None
    position_unit = "rad"

    def __init__(self, closed: tuple, open_loop: tuple, has_load: bool):
        self.a, self.b, self.c = closed
        self.open_a, self.open_b, self.open_c = open_loop
        self.has_load = has_load

    def poles(self) -> np.ndarray:
        return np.linalg.eigvals(self.a)

    def stable(self) -> bool:
        p = self.poles()
        return bool(np.all(p.real < 0))

    def context(self) -> Context:
        """The physical scales of this loop: its slowest time constant 1/min|p| [s]."""
        speeds = np.abs(self.poles())
        speeds = speeds[speeds > 0]
        return Context(time=1.0 / float(np.min(speeds)) if speeds.size else None,
                       position_unit=self.position_unit)

    def _response(self, a, b, c, d, omega) -> np.ndarray:
        """C(jωI − A)⁻¹B + D at each ω ≥ 0 [rad/s]. jωI − A is written into one array, its
        real part −A and its diagonal's imaginary part ω: the entries of
        ``1j * ω * eye(n) − A`` to the bit, without that expression's three temporaries of
        N·n² complex numbers (for the grid's 2 000 points of an 8 × 8 loop, 1.7 of its 5 ms)."""
        omega = np.atleast_1d(np.asarray(omega, dtype=float))
        n = a.shape[0]
        m = np.empty((omega.size, n, n), dtype=complex)
        m.real = 0.0 - a
        m.imag = 0.0
        m.imag[:, range(n), range(n)] = omega[:, None]
        return np.linalg.solve(m, np.broadcast_to(b, (omega.size, n, 1)))[:, :, 0] @ c + d

    def frequency_response(self, omega) -> tuple[np.ndarray, np.ndarray]:
        """(L, H): L = θ/e_p with the position feedback opened, H = θ/θ_i."""
        return self._open(omega), self._response(self.a, self.b[:, :1], self.c, 0.0, omega)

    def velocity_constant(self) -> float:
        """C_v = 1/e_ss [1/s]: e_ss = −C p0 of the ramp's steady solution x = p0 + p1 t,
        p1 = −A⁻¹B, p0 = A⁻¹p1 (Bhatia Ch. IV A (c))."""
        p1 = -np.linalg.solve(self.a, self.b[:, 0])
        p0 = np.linalg.solve(self.a, p1)
        return float(-1.0 / (self.c @ p0))

    def _grid(self) -> np.ndarray:
        """The frequency grid [rad/s], once per model (every frequency measure reads it; it
        takes the closed and open loops' eigenvalues)."""
        grid = self.__dict__.get("_frequency_grid")
        if grid is None:
            speeds = np.abs(np.concatenate([self.poles(), np.linalg.eigvals(self.open_a)]))
            speeds = speeds[speeds > 0]
            low, high = np.min(speeds) / FREQUENCY_SPAN, np.max(speeds) * FREQUENCY_SPAN
            count = int(POINTS_PER_DECADE * math.log10(high / low)) + 1
            grid = self.__dict__["_frequency_grid"] = np.logspace(math.log10(low),
                                                                  math.log10(high), count)
        return grid

    def _gain(self, omega) -> np.ndarray:
        """|H(jω)/H(0)|."""
        return np.abs(self._response(self.a, self.b[:, :1], self.c, 0.0, omega)
                      / self._static_gain)

    @functools.cached_property
    def _static_gain(self) -> float:
        """H(0) [1] of :meth:`_gain`, −C A⁻¹ B on the reference's column (once per model:
        Brent's refinement of M_peak asks for one ω at a time)."""
        return -self.c @ np.linalg.solve(self.a, self.b[:, 0])

    def _open(self, omega) -> np.ndarray:
        return self._response(self.open_a, self.open_b, self.open_c, 0.0, omega)

    def m_peak(self) -> float:
        """sup_ω |H(jω)/H(0)| [1] (at least 1, the limit ω → 0): every local maximum of the
        grid above 1 + 1e-9 refined by Brent.

        Where |H/H(0)| sits at 1 to rounding (the low-frequency plateau of a type-2 loop), its
        noise makes a local maximum of every other point, and none of them can beat the
        floor 1 by more than the tolerance (1e-6): refining them all cost a minute on a
        type-2 loop (11 418 Brent searches)."""
        grid = self._grid()
        g = self._gain(grid)
        best = max(1.0, float(np.max(g)))  # |H/H(0)| → 1 as ω → 0
        peaks = (g[1:-1] >= g[:-2]) & (g[1:-1] >= g[2:]) & (g[1:-1] > 1 + 1e-9)
        for i in np.nonzero(peaks)[0] + 1:
            res = minimize_scalar(lambda u: -self._gain(math.exp(u))[0],
                                  bounds=(math.log(grid[i - 1]), math.log(grid[i + 1])),
                                  method="bounded", options={"xatol": 1e-12})
            best = max(best, -float(res.fun))
        return best

    def sensitivity_peak(self) -> float:
        """M_s = sup_ω |1/(1 + L(jω))| [1] (at least 1, the limit ω → ∞ of a strictly
        proper L): every local maximum of the grid refined by Brent, as :meth:`m_peak`."""
        grid = self._grid()

        def size(omega):
            return np.abs(1.0 / (1.0 + self._open(omega)))

        s = size(grid)
        best = max(1.0, float(np.max(s)))
        # |S| sits at 1 to rounding above the bandwidth: its noise makes a local maximum of
        # every other point there, and none of them can beat the floor 1 by more than the
        # tolerance (1e-6), so only peaks above 1 + 1e-9 are refined
        peaks = (s[1:-1] >= s[:-2]) & (s[1:-1] >= s[2:]) & (s[1:-1] > 1 + 1e-9)
        for i in np.nonzero(peaks)[0] + 1:
            res = minimize_scalar(lambda u: -size(math.exp(u))[0],
                                  bounds=(math.log(grid[i - 1]), math.log(grid[i + 1])),
                                  method="bounded", options={"xatol": 1e-12})
            best = max(best, -float(res.fun))
        return best

    def _first_crossing(self, fn, level: float) -> float:
        """Lowest ω of the grid where fn − level changes sign, refined by brentq."""
        grid = self._grid()
        values = fn(grid) - level
        changes = np.nonzero(np.sign(values[:-1]) != np.sign(values[1:]))[0]
        if changes.size == 0:
            raise NotCovered("no crossing in the frequency range")
        i = changes[0]
        return float(math.exp(brentq(lambda u: fn(math.exp(u))[0] - level,
                                     math.log(grid[i]), math.log(grid[i + 1]), xtol=1e-14)))

    def bandwidth(self) -> float:
        """Lowest ω [rad/s] with |H/H(0)| = 1/√2."""
        return self._first_crossing(lambda w: self._gain(w) ** 2, 0.5)

    def crossover(self) -> float:
        """Lowest ω [rad/s] with |L| = 1."""
        return self._first_crossing(lambda w: np.log(np.abs(self._open(w))), 0.0)

    def phase_margin(self) -> float:
        """180° + arg L(jω_c) [deg], arg taken in (−360°, 0°]."""
        lo = self._open(self.crossover())[0]
        return math.degrees(math.atan2(-lo.imag, -lo.real))

    def gain_margin(self) -> float:
        """1/|L| [1] at the lowest ω where L crosses the negative real axis (the unwrapped
        phase crosses −180°), located where Im L/|L| changes sign, refined by brentq; +∞
        where the phase never reaches −180° on the grid (python-control's gm = inf)."""
        grid = self._grid()
        phase = np.unwrap(np.angle(self._open(grid)))
        turns = np.nonzero(np.sign(phase[:-1] + math.pi) != np.sign(phase[1:] + math.pi))[0]
        if turns.size == 0:
            return math.inf
        i = turns[0]

        def imag(u):
            lo = self._open(math.exp(u))[0]
            return lo.imag / abs(lo)

        omega = math.exp(brentq(imag, math.log(grid[i]), math.log(grid[i + 1]), xtol=1e-14))
        return float(1.0 / abs(self._open(omega)[0]))

    # -- time responses ----------------------------------------------------------------

    def _augmented(self, kind: str):
        """(M, z0, out): the state [x, inputs] with z' = M z, z(0) = z0, θ = out @ z."""
        n = self.a.shape[0]
        if kind == "ramp":  # θ_i = t: states [x, θ_i, 1]
            m = np.zeros((n + 2, n + 2))
            m[:n, :n], m[:n, n], m[n, n + 1] = self.a, self.b[:, 0], 1.0
            z0 = np.zeros(n + 2)
            z0[n + 1] = 1.0
            return m, z0, np.concatenate([self.c, [0.0, 0.0]])
        column = self.b[:, 0] if kind == "step" else self.b[:, 1]
        m = np.zeros((n + 1, n + 1))
        m[:n, :n], m[:n, n] = self.a, column
        z0 = np.zeros(n + 1)
        z0[n] = 1.0
        return m, z0, np.concatenate([self.c, [0.0]])

    def _grid_steps(self) -> np.ndarray:
        """Graded time steps [s] until the slowest mode has decayed to SETTLED: each step
        at most FINE/|p| of the fastest mode still alive (e^{Re p·t} > ALIVE), growing by at
        most GROWTH per step, so stiff modes are resolved while they last and no longer.
        Computed once per model (every response shares them)."""
        steps = self.__dict__.get("_steps")
        if steps is None:
            steps = self.__dict__["_steps"] = self._graded_steps()
        return steps

    def _graded_steps(self) -> np.ndarray:
        p = self.poles()
        if np.max(p.real) >= 0:
            raise ValueError("unstable loop: the responses do not settle")
        speeds, decay = np.abs(p), -p.real
        end = math.log(1 / SETTLED) / float(np.min(decay))
        order = np.argsort(-speeds)  # fastest first
        # a mode is alive until e^{−decay·t} = ALIVE
        dies = math.log(1 / ALIVE) / decay[order]
        steps, t, h = [], 0.0, FINE / float(speeds[order[0]])
        k, last = 0, len(order) - 1
        while t < end:
            while k < last and dies[k] <= t:
                k += 1
            cap = FINE / float(speeds[order[k]])
            h = min(h * GROWTH, cap)
            steps.append(h)
            t += h
            if h == cap:  # h stays at cap while this mode lives: the run at once
                run, t = _run(t, cap, end if k == last else min(end, float(dies[k])))
                steps.extend(run)
        return np.concatenate([np.atleast_1d(np.asarray(s, dtype=float)) for s in steps])

    def _simulate(self, kind: str):
        """(t, θ, exact) on the graded grid; exact(t) evaluates θ anywhere (the kind's own
        augmented matrix, :meth:`_augmented`)."""
        m, z0, out = self._augmented(kind)
        t, thetas = self._simulate_all()
        return t, thetas[kind], lambda tt: float(out @ expm(m * tt) @ z0)

    def _simulate_all(self) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """(t, kind → θ on t): the step, ramp and unit-load responses in one propagation,
        computed once per model.

        One augmented state z = [x, θ_i, c, T_L] with x' = A x + B [θ_i, T_L], θ_i' = c,
        c' = T_L' = 0 carries all three: z(0) = e_θi is the unit step (θ_i stays 1),
        e_c the unit ramp (θ_i = t), e_TL the unit load torque. So each time step is one
        e^{Mh} (scipy's expm) for all three instead of one per response, and each state
        update one product with a 3-column matrix; the inputs are exact as before.
        """
        cached = self.__dict__.get("_responses")
        if cached is None:
            n = self.a.shape[0]
            m = np.zeros((n + 3, n + 3))
            m[:n, :n], m[:n, n], m[:n, n + 2], m[n, n + 1] = (
                self.a, self.b[:, 0], self.b[:, 1], 1.0)
            z0 = np.zeros((n + 3, 3))
            z0[n, 0] = z0[n + 1, 1] = z0[n + 2, 2] = 1.0
            steps = self._grid_steps()
            t = grid_times(steps)
            theta = _propagate(m, z0, steps, np.concatenate([self.c, np.zeros(3)]))
            cached = self.__dict__["_responses"] = (
                t, {"step": theta[:, 0], "ramp": theta[:, 1], "load": theta[:, 2]})
        return cached

    def responses(self) -> dict[str, Response]:
        out = {}
        for kind in ("step", "ramp") + (("load",) if self.has_load else ()):
            t, theta, _ = self._simulate(kind)
            reference = {"step": np.ones_like(t), "ramp": t, "load": np.zeros_like(t)}[kind]
            unit = "rad/(N·m)" if kind == "load" else self.position_unit
            out[kind] = Response(kind, t, reference, theta, unit)
        return out

    def circle_test(self, radius, feed):
        raise NotCovered("no two-axis circle test for this loop")

    # -- time-domain metrics -----------------------------------------------------------

    def _error(self, kind: str):
        """(t, e − e_ss, exact(t) of e − e_ss, e_ss) with e = θ_i − θ (step, ramp) or
        e = −θ per unit load torque."""
        t, theta, exact = self._simulate(kind)
        if kind == "step":
            return t, 1.0 - theta, (lambda tt: 1.0 - exact(tt)), 0.0
        if kind == "ramp":
            steady = 1.0 / self.velocity_constant()
            return t, t - theta - steady, (lambda tt: tt - exact(tt) - steady), steady
        steady = float(self.c @ np.linalg.solve(self.a, self.b[:, 1]))  # −θ(∞) = C A⁻¹ B_L
        return t, -theta - steady, (lambda tt: -exact(tt) - steady), steady

    @staticmethod
    def _extreme(t, values, exact, sign: float) -> float:
        """max of sign·value over the grid, refined by Brent around the best grid point."""
        i = int(np.argmax(sign * values))
        best = float(sign * values[i])
        if 0 < i < t.size - 1:
            res = minimize_scalar(lambda tt: -sign * exact(tt), bounds=(t[i - 1], t[i + 1]),
                                  method="bounded", options={"xatol": 1e-14 * t[i + 1]})
            best = max(best, -float(res.fun))
        return best

    @staticmethod
    def _last_exit(t, values, exact, band: float) -> float:
        outside = np.nonzero(np.abs(values) > band)[0]
        if outside.size == 0:
            return 0.0
        i = outside[-1]
        if i == t.size - 1:
            raise ValueError("the response has not settled at the end of the grid")
        side = math.copysign(band, values[i])
        return float(brentq(lambda tt: exact(tt) - side, t[i], t[i + 1], xtol=1e-15))

    def error(self, kind: str, cache: dict):
        """:meth:`_error` of ``kind``, once per result (``cache`` of one measure pass)."""
        key = ("error", kind)
        if key not in cache:
            cache[key] = self._error(kind)
        return cache[key]

    def measurement_tables(self) -> tuple[Phase, ...]:
        """:data:`CONTINUOUS_MEASUREMENTS`."""
        return (Phase(CONTINUOUS_MEASUREMENTS),)

    def measure(self, result: dict) -> list[dict]:
        """Entries for every frequency- and time-domain metric the result reports that
        :meth:`measurement_tables` declares, judged by
        :func:`feedtune.validate.tolerances.judge`."""
        return measure_entries(self, self.measurement_tables(), result, self.context())


def _integral(model: ContinuousModel, options: dict, cache: dict, name: str) -> float:
    t, e, _, _ = model.error(options.get("input", "step"), cache)
    return error_integrals(t, e, (name,))[name]


def _overshoot(model: ContinuousModel, options: dict, reported, cache: dict) -> float:
    t, e, exact, _ = model.error("step", cache)
    return max(0.0, model._extreme(t, -e, lambda tt: -exact(tt), 1.0))


def _settling_time(model: ContinuousModel, options: dict, reported, cache: dict) -> float:
    kind = options.get("input", "step")
    t, e, exact, steady = model.error(kind, cache)
    size = 1.0 if kind == "step" or steady == 0 else abs(steady)  # as the metric
    return model._last_exit(t, e, exact, options.get("band", 0.02) * size)


def _load_rejection(model: ContinuousModel, options: dict, reported, cache: dict) -> float:
    t, e, exact, steady = model.error("load", cache)
    if options.get("measure", "peak") == "iae":
        return error_integrals(t, e, ("iae",))["iae"]
    # |e| = |e − e_ss + e_ss|, the static error included
    value = max(model._extreme(t, e + steady, lambda tt: exact(tt) + steady, s)
                for s in (1.0, -1.0))
    return max(value, abs(steady))


def _radial_error(model: ContinuousModel, options: dict, reported, cache: dict) -> float:
    """r·| |H(jω)| − 1 | [m], ω = feed/r, H = position/reference (feed-forward included):
    the steady circle of two identical axes (Koren eqs 28, 37 in exact form), |H| − 1
    written (|H|² − 1)/(|H| + 1). H ≈ 1 leaves rounding of ~1e-16 in |H|² − 1, i.e.
    1e-16·r, far below the entry's scale BLU/1000 or 1e-9·r (tolerances.RULES)."""
    radius, omega = options["radius"], options["feed"] / options["radius"]
    h = abs(model.frequency_response(omega)[1][0])
    return float(radius * abs((h * h - 1.0) / (h + 1.0)))


def _pole_pair(model: ContinuousModel, options: dict, reported, cache: dict) -> tuple:
    """(ζ, ω_n [rad/s]) of a second-order loop's poles p1, p2: ω_n = √(p1 p2),
    ζ = −(p1 + p2)/(2ω_n)."""
    poles = model.poles()
    wn = math.sqrt(abs((poles[0] * poles[1]).real))
    return -float(poles.sum().real) / (2 * wn), wn


def _second_order(model, options: dict) -> bool:
    return model.poles().size == 2


#: ζ and ω_n of a continuous second-order loop (Sato's Padé model, a user-defined loop of
#: order 2): each model that has them adds these to its table
PAIR_MEASUREMENTS: dict[str, Measurement] = {
    "damping_ratio": Measurement(lambda m, o, r, c: _pole_pair(m, o, r, c)[0], _second_order),
    "natural_frequency": Measurement(lambda m, o, r, c: _pole_pair(m, o, r, c)[1],
                                     _second_order),
}


def _absolute_time(model, options: dict) -> bool:
    return options.get("time", "absolute") == "absolute"


#: ContinuousModel (Bhatia's cascades, the user-defined loop, Sato's Padé model): metric →
#: measurement; a subclass adds its own in ``measurement_tables``
CONTINUOUS_MEASUREMENTS: dict[str, Measurement] = {
    "m_peak": Measurement(lambda m, o, r, c: m.m_peak()),
    "sensitivity_peak": Measurement(lambda m, o, r, c: m.sensitivity_peak()),
    "bandwidth": Measurement(lambda m, o, r, c: m.bandwidth()),
    "crossover_frequency": Measurement(lambda m, o, r, c: m.crossover()),
    "phase_margin": Measurement(lambda m, o, r, c: m.phase_margin()),
    "gain_margin": Measurement(lambda m, o, r, c: m.gain_margin()),
    "velocity_constant": Measurement(lambda m, o, r, c: m.velocity_constant()),
    **{name: Measurement(lambda m, o, r, c, name=name: _integral(m, o, c, name), _absolute_time)
       for name in ("iae", "ise", "itae")},
    "overshoot": Measurement(_overshoot),
    "settling_time": Measurement(_settling_time),
    "load_rejection": Measurement(_load_rejection, lambda m, o: m.has_load),
    "radial_error": Measurement(_radial_error),
}

#: |G(0)·K_v·K_p| (Bhatia Ch. IV eq 1), for the models with a ``sensitivity()`` method
#: (the cascades, the user-defined loop): each adds it to its table
SENSITIVITY = Measurement(lambda m, o, r, c: m.sensitivity())
