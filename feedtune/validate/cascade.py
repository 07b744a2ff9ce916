"""Bhatia's two-loop cascade (Fig 18/33) as a state-space model of numbers, for the validator.

A drive is given as a state-space block from armature/valve volts u [V] and load torque
T_L [N·m] to shaft velocity θ̇ [rad/s] (written from the drive's physics by its module);
compensators are state-space blocks of their transfer functions (Bhatia Table 5, App. C).
The loops are closed by writing every signal of Fig 18 as a linear map of the states and
inputs,

    e_p = θ_i − θ,  v = K'_p·Gc_p(e_p),  e_v = v − θ̇,  u = K'_v·Gc_v(e_v),  θ' = θ̇,

not from the closed-loop polynomial the tuner uses. Frequency responses are
C(jωI − A)⁻¹B + D on a dense grid, refined by Brent's method; time responses are the
exact state on a graded grid (scipy.linalg.expm of the augmented matrix, so the input is
exact too), extremes and band exits refined by Brent's method on the exact state.

References
----------
S. Bhatia, "Feed drive design for numerically controlled machine tools", M.S. thesis,
University of Missouri–Rolla, 1971, Ch. IV (Fig 18, eq 1), Table 5, App. C.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm
from scipy.optimize import brentq, minimize_scalar

from feedtune.validate.entries import entry, poles_entry
from feedtune.validate.integrals import error_integrals
from feedtune.validate.model import NotCovered, Response

#: the response is simulated until the slowest mode has decayed to this fraction
SETTLED = 1e-12
#: grid step [s]: at most FINE/|p| of the fastest mode still above ALIVE (relative), growing
#: by at most GROWTH per step
FINE, GROWTH, ALIVE = 0.01, 1.02, 1e-10
#: frequency grid [points per decade] over FREQUENCY_SPAN beyond the slowest/fastest pole
POINTS_PER_DECADE, FREQUENCY_SPAN = 200, 1e3

TOLERANCES = {
    # Brent on exact expressions on both sides (tuner: Newton on the exact response)
    "m_peak": 1e-6, "bandwidth": 1e-6, "crossover_frequency": 1e-6, "phase_margin": 1e-6,
    "gain_margin": 1e-6,
    # closed forms: a linear solve on each side
    "velocity_constant": 1e-9, "sensitivity": 1e-9,
    # trapezoid on the graded grid, step ≤ 0.01/|p|: relative error ~(0.01)²/12 ≈ 1e-5
    "iae": 1e-4, "ise": 1e-4, "itae": 1e-4, "load_rejection(iae)": 1e-4,
    # extremes and band exits refined by Brent's method on the exact state
    "overshoot": 1e-6, "settling_time": 1e-6, "load_rejection(peak)": 1e-6,
}


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


def siso(numerator: list, denominator: list) -> Block:
    """A proper n(s)/d(s) (highest power first) in controllable canonical form."""
    num = np.trim_zeros(np.atleast_1d(np.asarray(numerator, dtype=float)), "f")
    den = np.trim_zeros(np.atleast_1d(np.asarray(denominator, dtype=float)), "f")
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


def compensator(kind: str, prefix: str, tuned: dict) -> Block:
    """none: 1; lag: (1 + τ1 s)/(1 + τ2 s) (Table 5); lag_lead: (1 + τ1 s)(1 + τ2 s)/
    (τ1τ2 s² + (τ1 + τ2 + τ12)s + 1) (App. C)."""
    if kind == "none":
        return siso([1.0], [1.0])
    t1, t2 = tuned[f"{prefix}.tau1"], tuned[f"{prefix}.tau2"]
    if kind == "lag":
        return siso([t1, 1.0], [t2, 1.0])
    t12 = tuned[f"{prefix}.tau12"]
    return siso([t1 * t2, t1 + t2, 1.0], [t1 * t2, t1 + t2 + t12, 1.0])


class CascadeModel:
    """Position loop around a velocity loop around ``drive`` (inputs u, T_L → θ̇)."""

    sampled = False
    period = None
    position_unit = "rad"

    def __init__(self, drive: Block, position_gain: float, velocity_gain: float,
                 position_compensator: Block, velocity_compensator: Block, has_load: bool):
        if np.any(drive.d):
            raise ValueError("the drive must be strictly proper (no direct feedthrough)")
        self.drive, self.kp, self.kv = drive, position_gain, velocity_gain
        self.cp, self.cv, self.has_load = position_compensator, velocity_compensator, has_load
        self.a, self.b, self.c = self._closed()

    @classmethod
    def from_parts(cls, drive: Block, plant: dict, tuned: dict, has_load: bool):
        return cls(drive, tuned["position_gain"], tuned["velocity_gain"],
                   compensator(plant.get("position_compensator", "none"),
                               "position_compensator", tuned),
                   compensator(plant.get("velocity_compensator", "none"),
                               "velocity_compensator", tuned), has_load)

    # -- the interconnection -----------------------------------------------------------

    def _slices(self):
        p, v, d = self.cp.order, self.cv.order, self.drive.order
        return slice(0, p), slice(p, p + v), slice(p + v, p + v + d), p + v + d

    def _closed(self, open_at_position: bool = False):
        """(A, B, C) with inputs [θ_i, T_L] (or [e_p, T_L] when the loop is opened at the
        position feedback) and output θ; states [Gc_p, Gc_v, drive, θ]."""
        sp, sv, sd, it = self._slices()
        n = it + 1
        x = np.eye(n)
        w = np.eye(2)  # input rows: [reference or e_p, T_L]

        def signal(xrow, wrow):  # a linear map (row over states, row over inputs)
            return np.asarray(xrow, dtype=float), np.asarray(wrow, dtype=float)

        e_p = signal(np.zeros(n) if open_at_position else -x[it], w[0])
        y_p = signal(self.cp.c[0] @ x[sp] + self.cp.d[0, 0] * e_p[0], self.cp.d[0, 0] * e_p[1])
        v = signal(self.kp * y_p[0], self.kp * y_p[1])
        velocity = signal(self.drive.c[0] @ x[sd], np.zeros(2))
        e_v = signal(v[0] - velocity[0], v[1] - velocity[1])
        y_v = signal(self.cv.c[0] @ x[sv] + self.cv.d[0, 0] * e_v[0], self.cv.d[0, 0] * e_v[1])
        u = signal(self.kv * y_v[0], self.kv * y_v[1])
        a, b = np.zeros((n, n)), np.zeros((n, 2))
        a[sp] = self.cp.a @ x[sp] + np.outer(self.cp.b[:, 0], e_p[0])
        b[sp] = np.outer(self.cp.b[:, 0], e_p[1])
        a[sv] = self.cv.a @ x[sv] + np.outer(self.cv.b[:, 0], e_v[0])
        b[sv] = np.outer(self.cv.b[:, 0], e_v[1])
        a[sd] = self.drive.a @ x[sd] + np.outer(self.drive.b[:, 0], u[0])
        b[sd] = np.outer(self.drive.b[:, 0], u[1]) + np.outer(self.drive.b[:, 1], w[1])
        a[it], b[it] = velocity
        return a, b, x[it]

    def _inner(self) -> np.ndarray:
        """State matrix of the velocity loop alone (input v, output θ̇): [Gc_v, drive]."""
        v, d = self.cv.order, self.drive.order
        n = v + d
        a = np.zeros((n, n))
        velocity = np.concatenate([np.zeros(v), self.drive.c[0]])
        e_v = -velocity
        u = self.kv * (np.concatenate([self.cv.c[0], np.zeros(d)]) + self.cv.d[0, 0] * e_v)
        a[:v, :v] = self.cv.a
        a[:v] += np.outer(self.cv.b[:, 0], e_v)
        a[v:, v:] = self.drive.a
        a[v:] += np.outer(self.drive.b[:, 0], u)
        return a

    # -- the Model protocol ------------------------------------------------------------

    def poles(self) -> np.ndarray:
        return np.linalg.eigvals(self.a)

    def stable(self) -> bool:
        p = self.poles()
        return bool(np.all(p.real < 0))

    def _response(self, a, b, c, d, omega) -> np.ndarray:
        omega = np.atleast_1d(np.asarray(omega, dtype=float))
        n = a.shape[0]
        m = 1j * omega[:, None, None] * np.eye(n) - a
        return np.linalg.solve(m, np.broadcast_to(b, (omega.size, n, 1)))[:, :, 0] @ c + d

    def frequency_response(self, omega) -> tuple[np.ndarray, np.ndarray]:
        """(L, H): L = θ/e_p with the position feedback opened, H = θ/θ_i."""
        a_open, b_open, c = self._closed(open_at_position=True)
        return (self._response(a_open, b_open[:, :1], c, 0.0, omega),
                self._response(self.a, self.b[:, :1], self.c, 0.0, omega))

    def velocity_constant(self) -> float:
        """C_v = 1/e_ss [1/s]: e_ss = −C p0 of the ramp's steady solution x = p0 + p1 t,
        p1 = −A⁻¹B, p0 = A⁻¹p1 (Bhatia Ch. IV A (c))."""
        p1 = -np.linalg.solve(self.a, self.b[:, 0])
        p0 = np.linalg.solve(self.a, p1)
        return float(-1.0 / (self.c @ p0))

    def sensitivity(self) -> float:
        """|G(0) K'_v K'_p| [1/s], G(0) = −C_d A_d⁻¹ B_d the drive's DC velocity per volt
        (Bhatia Ch. IV eq 1)."""
        g0 = -self.drive.c[0] @ np.linalg.solve(self.drive.a, self.drive.b[:, 0])
        return float(abs(g0 * self.kv * self.kp))

    # -- frequency-domain metrics ------------------------------------------------------

    def _grid(self) -> np.ndarray:
        speeds = np.abs(np.concatenate([self.poles(), np.linalg.eigvals(self._closed(True)[0])]))
        speeds = speeds[speeds > 0]
        low, high = np.min(speeds) / FREQUENCY_SPAN, np.max(speeds) * FREQUENCY_SPAN
        count = int(POINTS_PER_DECADE * math.log10(high / low)) + 1
        return np.logspace(math.log10(low), math.log10(high), count)

    def _gain(self, omega) -> np.ndarray:
        """|H(jω)/H(0)|."""
        h = self._response(self.a, self.b[:, :1], self.c, 0.0, omega)
        h0 = -self.c @ np.linalg.solve(self.a, self.b[:, 0])
        return np.abs(h / h0)

    def _open(self, omega) -> np.ndarray:
        a_open, b_open, c = self._closed(open_at_position=True)
        return self._response(a_open, b_open[:, :1], c, 0.0, omega)

    def m_peak(self) -> float:
        """max_ω |H(jω)/H(0)| [1]: every local maximum of the grid refined by Brent."""
        grid = self._grid()
        g = self._gain(grid)
        best = float(np.max(g))
        for i in np.nonzero((g[1:-1] >= g[:-2]) & (g[1:-1] >= g[2:]))[0] + 1:
            res = minimize_scalar(lambda u: -self._gain(math.exp(u))[0],
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
        phase crosses −180°), located where Im L/|L| changes sign, refined by brentq."""
        grid = self._grid()
        phase = np.unwrap(np.angle(self._open(grid)))
        turns = np.nonzero(np.sign(phase[:-1] + math.pi) != np.sign(phase[1:] + math.pi))[0]
        if turns.size == 0:
            raise NotCovered("the open-loop phase never reaches −180°")
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
        most GROWTH per step, so stiff modes are resolved while they last and no longer."""
        p = self.poles()
        if np.max(p.real) >= 0:
            raise ValueError("unstable loop: the responses do not settle")
        speeds, decay = np.abs(p), -p.real
        end = math.log(1 / SETTLED) / float(np.min(decay))
        order = np.argsort(-speeds)  # fastest first
        # a mode is alive until e^{−decay·t} = ALIVE
        dies = math.log(1 / ALIVE) / decay[order]
        steps, t, h = [], 0.0, FINE / float(speeds[order[0]])
        k = 0
        while t < end:
            while k < len(order) - 1 and dies[k] <= t:
                k += 1
            h = min(h * GROWTH, FINE / float(speeds[order[k]]))
            steps.append(h)
            t += h
        return np.asarray(steps)

    def _simulate(self, kind: str):
        """(t, θ, exact) on the graded grid; exact(t) evaluates θ anywhere."""
        m, z0, out = self._augmented(kind)
        steps = self._grid_steps()
        t = np.concatenate([[0.0], np.cumsum(steps)])
        theta = np.empty(t.size)
        z = z0.copy()
        theta[0] = out @ z
        cache: dict[float, np.ndarray] = {}
        for i, h in enumerate(steps, start=1):
            step = cache.get(h)
            if step is None:
                step = cache[h] = expm(m * h)
            z = step @ z
            theta[i] = out @ z
        return t, theta, lambda tt: float(out @ expm(m * tt) @ z0)

    def responses(self) -> dict[str, Response]:
        out = {}
        for kind in ("step", "ramp") + (("load",) if self.has_load else ()):
            t, theta, _ = self._simulate(kind)
            reference = {"step": np.ones_like(t), "ramp": t, "load": np.zeros_like(t)}[kind]
            unit = "rad/(N·m)" if kind == "load" else self.position_unit
            out[kind] = Response(kind, t, reference, theta, unit)
        return out

    def circle_test(self, radius, feed):
        raise NotCovered("a rotary axis: no two-axis circle test")

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

    def measure(self, result: dict) -> list[dict]:
        """Entries for every metric of Bhatia's loops the result reports."""
        entries, cache = [], {}

        def error(kind):
            if kind not in cache:
                cache[kind] = self._error(kind)
            return cache[kind]

        closed_forms = {"m_peak": self.m_peak, "bandwidth": self.bandwidth,
                        "crossover_frequency": self.crossover, "phase_margin": self.phase_margin,
                        "gain_margin": self.gain_margin, "velocity_constant": self.velocity_constant,
                        "sensitivity": self.sensitivity}
        for m in result.get("metrics", {}).values():
            name, options, reported = m["metric"], m.get("options") or {}, m.get("value")
            if reported is None or (isinstance(reported, float) and math.isinf(reported)):
                continue
            if name in closed_forms:
                try:
                    value = closed_forms[name]()
                except NotCovered:
                    continue
                entries.append(entry(name, options, reported, value, TOLERANCES[name]))
            elif name in ("iae", "ise", "itae") and options.get("time", "absolute") == "absolute":
                t, e, _, _ = error(options.get("input", "step"))
                entries.append(entry(name, options, reported, error_integrals(t, e)[name],
                                     TOLERANCES[name]))
            elif name == "overshoot":
                t, e, exact, _ = error("step")
                value = max(0.0, self._extreme(t, -e, lambda tt: -exact(tt), 1.0))
                entries.append(entry(name, options, reported, value, TOLERANCES[name]))
            elif name == "settling_time":
                kind = options.get("input", "step")
                t, e, exact, steady = error(kind)
                size = 1.0 if kind == "step" else abs(steady)
                value = self._last_exit(t, e, exact, options.get("band", 0.02) * size)
                entries.append(entry(name, options, reported, value, TOLERANCES[name]))
            elif name == "load_rejection" and self.has_load:
                t, e, exact, steady = error("load")
                if options.get("measure", "peak") == "iae":
                    value = error_integrals(t, e)["iae"]
                else:  # |e| = |e − e_ss + e_ss|, the static error included
                    value = max(self._extreme(t, e + steady, lambda tt: exact(tt) + steady, s)
                                for s in (1.0, -1.0))
                    value = max(value, abs(steady))
                key = f"load_rejection({options.get('measure', 'peak')})"
                entries.append(entry(name, options, reported, value, TOLERANCES[key]))
        inner = (result.get("stability") or {}).get("inner_loop") or {}
        if inner.get("poles"):
            row = poles_entry(inner["poles"], np.linalg.eigvals(self._inner()), False)
            row["metric"] = "velocity_loop_poles"
            entries.append(row)
        return entries
