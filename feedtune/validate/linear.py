"""A user-defined linear drive and its controllers for the validator, from the spec's numbers.

The drive (``plant.model``: a transfer function, zeros/poles/gain via ``numpy.poly``, or
its own A, B, C, D) and each controller (P, PI, PID in standard form, Bhatia's lag or
lag-lead, the notch) are state-space blocks; the signals of the loop

    e_p = r − x,  v = C_p(e_p) + k_ff ṙ,  e_v = v − ẋ,  u = C_v(e_v)  (or u = C_p(e_p)),
    w = u delayed by θ,  y = P(w),  x = y or ∫y,  ẋ = ẏ or y,

are unknowns of one linear system solved at every state (time domain) or every frequency
(frequency domain), not the closed-loop polynomials the tuner uses. Time responses and
poles hold the dead time as its Padé approximant of the tuner's order, written here from
its closed form; frequency responses hold e^{−jωθ} exactly, each block's gain its transfer
function n(jω)/d(jω) (a state-space drive's C(jωI − A)⁻¹B + D), the system solved by
elimination along the loop cut at the drive's output (:meth:`LinearModel._signal_at`).
The metrics are measured by :class:`feedtune.validate.continuous.ContinuousModel`.

References
----------
S. Bhatia, "Feed drive design for numerically controlled machine tools", M.S. thesis,
University of Missouri–Rolla, 1971, Ch. IV (Fig 18, eq 1), App. C.
K. J. Åström, T. Hägglund, "Advanced PID Control", ISA, 2006, §3.1, §3.3.
G. A. Baker, P. Graves-Morris, "Padé Approximants", 2nd ed., 1996, §1.2.
"""

from __future__ import annotations

import cmath
import math
from dataclasses import replace

import numpy as np
from scipy.linalg import expm
from scipy.optimize import brentq

from feedtune.validate.cascade import compensator
from feedtune.validate.continuous import (PAIR_MEASUREMENTS, SENSITIVITY, Block, ContinuousModel,
                                         _propagate, grid_times, leading_zeros_trimmed, siso)
from feedtune.validate.entries import poles_entry
from feedtune.validate.measurements import Phase
from feedtune.validate.model import NotCovered

#: the order of the tuner's Padé approximant (feedtune.plants.linear_loop.PADE_ORDER): the
#: poles and time responses compared are those of the same approximation
PADE_ORDER = 4

#: signals, in the order of the unknown vector
SIGNALS = ("e_p", "c_p", "v", "e_v", "u", "w", "y", "x", "xdot")
#: the signals in an order in which, the drive's output y given, each follows from those
#: before it (frequency domain: :meth:`LinearModel._signal_at`)
CHAIN = ("x", "xdot", "e_p", "c_p", "v", "e_v", "u", "w")


def pade_block(dead_time: float) -> Block:
    """e^{−sθ} as its [n/n] Padé approximant: N(−sθ)/N(sθ), N(x) = Σ (2n−k)! n! /
    ((2n)! k! (n−k)!) x^k."""
    n = PADE_ORDER
    c = np.array([math.factorial(2 * n - k) * math.factorial(n)
                  / (math.factorial(2 * n) * math.factorial(k) * math.factorial(n - k))
                  for k in range(n + 1)])
    powers = dead_time ** np.arange(n + 1)
    return siso((c * powers * (-1.0) ** np.arange(n + 1))[::-1], (c * powers)[::-1])


def _horner(p: np.ndarray, s):
    """The polynomial ``p`` (highest power first) at ``s``, by Horner's rule as
    ``numpy.polyval`` (the same operations on an array), or at one Python complex number in
    Python's own arithmetic (≈ 15× cheaper than numpy.polyval on a 1-element array)."""
    value = 0j if isinstance(s, complex) else np.zeros_like(s)
    for coefficient in p.tolist():
        value = value * s + coefficient
    return value


def _polymul(a, b) -> np.ndarray:
    """``numpy.polymul(a, b)`` of two coefficient arrays (the convolution of the two with
    their leading zeros trimmed, a zero polynomial as [0]), without its two ``poly1d``."""
    a, b = leading_zeros_trimmed(a), leading_zeros_trimmed(b)
    return np.convolve(a if a.size else np.zeros(1), b if b.size else np.zeros(1))


def drive_transfer(model: dict) -> tuple[np.ndarray, np.ndarray]:
    """(numerator, denominator) of the drive, highest power first."""
    if model["type"] == "transfer_function":
        return np.asarray(model["numerator"], float), np.asarray(model["denominator"], float)
    if model["type"] == "zpk":
        def roots(items):
            out = []
            for r in items:
                out += [complex(r[0], r[1]), complex(r[0], -r[1])] if isinstance(r, list) else [r]
            return out

        return (model["gain"] * np.real(np.poly(roots(model.get("zeros", [])))),
                np.real(np.poly(roots(model["poles"]))))
    from scipy.signal import ss2tf  # 0.5 s of imports: only here
    num, den = ss2tf(*(np.asarray(model[k], float) for k in ("a", "b", "c")),
                     np.asarray(model.get("d", [[0.0]]), float))
    return num[0], den


def _zeros_at_origin(p: np.ndarray) -> int:
    """Roots at s = 0: trailing coefficients below 1e-12 of the largest (exact zeros from
    the spec's numbers; ss2tf leaves rounding of that relative size)."""
    p = np.trim_zeros(np.asarray(p, float), "f")
    small = np.abs(p) <= 1e-12 * np.max(np.abs(p))
    count = 0
    while count < len(p) - 1 and small[len(p) - 1 - count]:
        count += 1
    return count


def drive_block(model: dict) -> Block:
    """The drive as a state-space block (its own matrices for a state-space model)."""
    if model["type"] == "state_space":
        return Block(*(np.asarray(model[k], float) for k in ("a", "b", "c")),
                     np.asarray(model.get("d", [[0.0]]), float))
    return siso(*drive_transfer(model))


def controller_transfer(loop: str, plant: dict, tuned: dict) -> tuple[np.ndarray, np.ndarray]:
    """(numerator, denominator), highest power first, of the ``loop`` controller: law ×
    compensator × notch."""
    law = plant.get(f"{loop}_controller", "p")
    prefix = f"{loop}_controller"
    kp = tuned[f"{prefix}.kp"]
    num, den = np.array([kp]), np.array([1.0])
    if law in ("pi", "pid"):
        ti = tuned[f"{prefix}.ti"]
        num, den = _polymul(num, [ti, 1.0]), _polymul(den, [ti, 0.0])  # 1 + 1/(T_i s)
        if law == "pid":  # k_p(1 + 1/(T_i s) + T_d s/(T_d s/N + 1))
            td, tf = tuned[f"{prefix}.td"], tuned[f"{prefix}.td"] / tuned[f"{prefix}.n"]
            num = np.polyadd(_polymul(num, [tf, 1.0]), kp * ti * td * np.array([1.0, 0.0, 0.0]))
            den = _polymul(den, [tf, 1.0])
    comp = compensator(plant.get(f"{loop}_compensator", "none"), f"{loop}_compensator", tuned)
    if comp.order:
        from scipy.signal import ss2tf  # 0.5 s of imports: only for a compensator's states
        c_num, c_den = ss2tf(comp.a, comp.b, comp.c, comp.d)
    else:
        c_num, c_den = comp.d[0], [1.0]
    num, den = _polymul(num, np.ravel(c_num)), _polymul(den, c_den)
    if plant.get("notch", "none") == f"{loop}_loop":
        w, zeta, depth = (tuned[f"notch.{k}"] for k in ("frequency", "width", "depth"))
        num = _polymul(num, [1.0, 2 * depth * zeta * w, w * w])
        den = _polymul(den, [1.0, 2 * zeta * w, w * w])
    return num, den


def controller_block(loop: str, plant: dict, tuned: dict) -> Block:
    """The ``loop`` controller: law × compensator × notch, as one block."""
    return siso(*controller_transfer(loop, plant, tuned))


class LinearModel(ContinuousModel):
    """Validator model of ``linear``: a position loop, optionally around a velocity loop."""

    def __init__(self, plant: dict, tuned: dict):
        if plant.get("implementation", "continuous") != "continuous":
            # the continuous loop's measures would be compared with a discrete loop's numbers
            raise NotCovered("the sampled implementation of plant 'linear' is "
                             "SampledLinearModel's (LinearModel.from_result)")
        self.plant = plant
        self.position_output = plant["output_unit"] in ("m", "rad")
        self.position_unit = plant["output_unit"].removesuffix("/s")
        self.dead_time = plant.get("dead_time", 0.0)
        self.feedforward = plant.get("velocity_feedforward", 0.0)
        self.cascade = plant.get("velocity_controller", "none") != "none"
        self.drive = drive_block(plant["model"])
        if np.any(self.drive.d):
            raise NotCovered("a drive with direct feedthrough (D ≠ 0) is not modelled")
        #: each block's (numerator, denominator) for its frequency response; None: the
        #: drive's own A, B, C, D
        self.transfers = {
            "c_p": controller_transfer("position", plant, tuned),
            "c_v": controller_transfer("velocity", plant, tuned) if self.cascade else None,
            "drive": (None if plant["model"]["type"] == "state_space"
                      else drive_transfer(plant["model"])),
        }
        empty = Block(np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), np.ones((1, 1)))
        self.blocks = {
            "c_p": (siso(*self.transfers["c_p"]), "e_p"),
            "c_v": (siso(*self.transfers["c_v"]) if self.cascade else empty, "e_v"),
            "pade": (pade_block(self.dead_time) if self.dead_time > 0 else empty, "u"),
            "drive": (self.drive, "w"),
        }
        self.gains = {loop: tuned[f"{loop}_controller.kp"]
                      for loop in ("position", "velocity") if f"{loop}_controller.kp" in tuned}
        closed, b, c = self._state_space("closed")
        opened, b_open, c_open = self._state_space("open")
        super().__init__((closed, b[:, [0]], c), (opened, b_open[:, [2]], c_open), False)
        self.b = np.column_stack([b[:, 0], np.zeros(len(b)), b[:, 1]])  # [r, T_L (none), ṙ]

    @classmethod
    def from_result(cls, plant: dict, tuned: dict, stability: dict | None = None):
        """The model of a result's plant spec and tuned values (floats): this continuous
        loop, or :class:`feedtune.validate.sampled_linear.SampledLinearModel` for
        ``implementation: sampled`` (which a discrete drive, ``model.period``, requires)."""
        if plant.get("implementation", "continuous") == "sampled":
            from feedtune.validate.sampled_linear import SampledLinearModel

            return SampledLinearModel(plant, tuned)
        return cls(plant, tuned)

    # -- the interconnection -----------------------------------------------------------

    def _states(self) -> dict[str, slice]:
        out, start = {}, 0
        for name, (block, _) in self.blocks.items():
            out[name] = slice(start, start + block.order)
            start += block.order
        out["integral"] = slice(start, start + (0 if self.position_output else 1))
        return out

    def _signal_equations(self, mode: str):
        """(M, P, Q): signals σ = M σ + P x + Q [r, ṙ, e_open] at states x (time domain)."""
        states = self._states()
        n = states["integral"].stop
        k = {s: i for i, s in enumerate(SIGNALS)}
        m, p, q = np.zeros((9, 9)), np.zeros((9, n)), np.zeros((9, 3))
        if mode == "open":
            q[k["e_p"], 2] = 1.0
        elif mode == "closed":
            q[k["e_p"], 0], m[k["e_p"], k["x"]] = 1.0, -1.0
        # inner: the velocity command v is the input (column r), no position loop
        for name, target in (("c_p", "c_p"), ("c_v", "u"), ("pade", "w"), ("drive", "y")):
            block, source = self.blocks[name]
            if name == "c_v" and not self.cascade:
                m[k["u"], k["c_p"]] = 1.0
                continue
            p[k[target], states[name]] = block.c[0]
            m[k[target], k[source]] = block.d[0, 0]
        if mode == "inner":
            q[k["v"], 0] = 1.0
        else:
            m[k["v"], k["c_p"]], q[k["v"], 1] = 1.0, self.feedforward
        m[k["e_v"], k["v"]], m[k["e_v"], k["xdot"]] = 1.0, -1.0
        d = self.blocks["drive"][0]
        if self.position_output:  # x = y, ẋ = C A x_d + C B w (D = 0)
            m[k["x"], k["y"]] = 1.0
            p[k["xdot"], states["drive"]] = d.c[0] @ d.a
            m[k["xdot"], k["w"]] = float(d.c[0] @ d.b[:, 0])
        else:  # ẋ = y, x the integral state
            m[k["xdot"], k["y"]] = 1.0
            p[k["x"], states["integral"]] = 1.0
        return m, p, q

    def _state_space(self, mode: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(A, B, C) with inputs [r, ṙ, e_open] and output x of the loop: ``closed``,
        ``open`` at the position feedback, or the velocity loop alone (``inner``, input v)."""
        m, p, q = self._signal_equations(mode)
        solve = np.linalg.solve(np.eye(9) - m, np.hstack([p, q]))
        sig_x, sig_in = solve[:, :p.shape[1]], solve[:, p.shape[1]:]
        states = self._states()
        n = states["integral"].stop
        a, b = np.zeros((n, n)), np.zeros((n, 3))
        k = {s: i for i, s in enumerate(SIGNALS)}
        for name, (block, source) in self.blocks.items():
            sl = states[name]
            a[sl, sl] += block.a
            a[sl] += np.outer(block.b[:, 0], sig_x[k[source]])
            b[sl] += np.outer(block.b[:, 0], sig_in[k[source]])
        if not self.position_output:
            a[states["integral"]] += sig_x[k["xdot"]]
            b[states["integral"]] += sig_in[k["xdot"]]
        keep = self._kept(mode)
        return a[np.ix_(keep, keep)], b[keep], sig_x[k["x"], keep]

    def _kept(self, mode: str) -> np.ndarray:
        """States of the loop ``mode`` holds: the velocity loop alone has no position
        controller nor integral."""
        states = self._states()
        n = states["integral"].stop
        if mode != "inner":
            return np.arange(n)
        return np.array([i for name in ("c_v", "pade", "drive") for i in range(n)[states[name]]],
                        dtype=int)

    # -- frequency responses: the dead time exact ----------------------------------------

    def _gain_at(self, name: str, s):
        """Block ``name``'s gain at ``s`` (an array, or one Python complex): its transfer
        function n(s)/d(s) by Horner's rule (C(sI − A)⁻¹B + D of its controllable canonical
        form, which is n/d), or for a drive given by its own A, B, C, D that expression
        solved at each s."""
        transfer = self.transfers[name]
        if transfer is not None:
            num, den = transfer
            return _horner(num, s) / _horner(den, s)
        block = self.drive
        n = block.order
        points = np.atleast_1d(s)
        solved = np.linalg.solve(points[:, None, None] * np.eye(n) - block.a,
                                 np.broadcast_to(block.b, (points.size, n, 1)))[:, :, 0]
        gain = solved @ block.c[0] + block.d[0, 0]
        return gain if np.ndim(s) else complex(gain[0])

    def _system_at(self, omega, mode: str) -> tuple[np.ndarray, dict]:
        """(s, M): the signal equations σ = M σ + Q at s = jω (ω > 0), M as its nonzero
        entries (signal, source) → the gain from source to signal (a block's gain at each
        s, or a constant); the inputs Q are :meth:`_inputs_at`'s. An array ω gives arrays;
        one number ω (Brent's refinements ask for one at a time) gives Python complex
        numbers: a size-1 array's every numpy operation costs ≈ 1 µs, a number's 0.1 µs."""
        if np.ndim(omega):
            s = 1j * np.asarray(omega, dtype=float)
            delay = np.exp(-s * self.dead_time)
        else:
            s = 1j * float(omega)
            delay = cmath.exp(-s * self.dead_time)
        m = {("c_p", "e_p"): self._gain_at("c_p", s), ("v", "c_p"): 1.0,
             ("e_v", "v"): 1.0, ("e_v", "xdot"): -1.0,
             ("w", "u"): delay, ("y", "w"): self._gain_at("drive", s)}
        if mode != "open":
            m["e_p", "x"] = -1.0
        if self.cascade:
            m["u", "e_v"] = self._gain_at("c_v", s)
        else:
            m["u", "c_p"] = 1.0
        if self.position_output:
            m["x", "y"], m["xdot", "y"] = 1.0, s
        else:
            m["xdot", "y"], m["x", "y"] = 1.0, 1 / s
        return s, m

    def _inputs_at(self, s, mode: str) -> dict:
        """The signal equations' inputs Q at ``s`` (an array, or one Python complex), signal
        → value: a unit reference r (its rate ṙ = s r through the feed-forward), or the unit
        position error e_p where the loop is ``open``."""
        one = np.ones(s.size, dtype=complex) if np.ndim(s) else 1.0 + 0j
        if mode == "open":
            return {"e_p": one}
        return {"e_p": one, "v": self.feedforward * s}

    def _signal_at(self, omega, mode: str, signal: str = "x") -> np.ndarray:
        """``signal`` per unit input (:meth:`_inputs_at`) at s = jω (ω > 0): an array for
        an array ω, a 1-element array for one number.

        The signal equations σ = M σ + Q are solved by elimination along the loop, cut at
        the drive's output y: in the order of :data:`CHAIN` each signal is its row of M
        applied to those before it and y, once with y = 1 and no input (g: the chain's
        response per unit y) and once with the input and y = 0 (h). M's row of y then
        closes the loop, y = g_y y + h_y, so y = h_y/(1 − g_y) and every signal is
        h + y g: the same linear system, one division by the loop's return difference
        1 − g_y per frequency instead of a 9 × 9 LU factorisation. A source not yet known
        when its signal is reached (an equation the order does not cover) raises KeyError.
        One number ω is worked in Python complex numbers (:meth:`_system_at`), which round
        a product, a quotient or a modulus differently from numpy's loops in the last bit."""
        s, m = self._system_at(omega, mode)
        inputs = self._inputs_at(s, mode)
        zero = np.zeros(s.size, dtype=complex) if np.ndim(s) else 0j
        known = {"y": (zero + 1.0, zero)}  # each signal's (g, h)
        rows: dict[str, list] = {}
        for (target, source), gain in m.items():
            rows.setdefault(target, []).append((gain, source))

        def row(name: str) -> tuple:
            g = h = zero
            for i, (gain, source) in enumerate(rows.get(name, ())):
                g_source, h_source = known[source]
                g, h = ((g + gain * g_source, h + gain * h_source) if i
                        else (gain * g_source, gain * h_source))
            return g, (h + inputs[name] if name in inputs else h)

        for name in CHAIN:
            known[name] = row(name)
        g, h = row("y")
        value = known[signal][1] + h / (1.0 - g) * known[signal][0]
        return value if np.ndim(s) else np.array([value])

    def _open(self, omega) -> np.ndarray:
        return self._signal_at(omega, "open")

    def _closed(self, omega) -> np.ndarray:
        return self._signal_at(omega, "closed")

    def frequency_response(self, omega) -> tuple[np.ndarray, np.ndarray]:
        """(L, H): L = x/e_p with the position feedback opened, H = x/r (feed-forward
        included), the dead time exact."""
        return self._open(omega), self._closed(omega)

    def _gain(self, omega) -> np.ndarray:
        """|H(jω)/H(0)|, H(0) = 1 − (the ramp-free) C A⁻¹ B from the state space (once per
        model: ContinuousModel's ``_static_gain``)."""
        return np.abs(self._closed(omega) / self._static_gain)

    # -- time responses: the transient about the steady solution -------------------------

    def _steady(self, kind: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(p0, p1, δ0): the steady solution x = p0 + p1 t of ẋ = A x + B_r r + B_ṙ ṙ and
        the transient's start δ(0) = x(0⁺) − p0. Step: p1 = 0, p0 = −A⁻¹B_r, x(0⁺) = B_ṙ
        (k_ff·ṙ is an impulse); ramp: p1 = −A⁻¹B_r, p0 = A⁻¹(p1 − B_ṙ), x(0) = 0."""
        b_r, b_rate = self.b[:, 0], self.b[:, 2]
        settled = -np.linalg.solve(self.a, b_r)
        if kind == "step":
            return settled, np.zeros_like(settled), b_rate - settled
        p0 = np.linalg.solve(self.a, settled - b_rate)
        return p0, settled, -p0

    def _transients(self) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """(t, kind → C δ(t)): δ' = A δ propagated on the graded grid, once per model. The
        error about its steady value is −C δ exactly, with no ramp t − θ to cancel: this
        loop's A has a condition number up to 1e23 (a PI zero next to a slow pole), where
        ContinuousModel's augmented-input propagation loses 1e-10 of the ramp error."""
        cached = self.__dict__.get("_transient_values")
        if cached is None:
            steps = self._grid_steps()
            t = grid_times(steps)
            starts = np.column_stack([self._steady(kind)[2] for kind in ("step", "ramp")])
            values = _propagate(self.a, starts, steps, self.c)
            cached = self.__dict__["_transient_values"] = (
                t, {"step": values[:, 0], "ramp": values[:, 1]})
        return cached

    def _simulate(self, kind: str):
        """(t, x, exact(t)) of the step or ramp response."""
        t, values = self._transients()
        p0, p1, d0 = self._steady(kind)
        c = self.c
        return (t, c @ p0 + (c @ p1) * t + values[kind],
                lambda tt: float(c @ p0 + (c @ p1) * tt + c @ expm(self.a * tt) @ d0))

    def _error(self, kind: str):
        """(t, e − e_ss, exact(t) of e − e_ss, e_ss) after a unit step or ramp: e − e_ss =
        −C δ(t); e_ss = 0 after a step, −C p0 after a ramp (1/C_v without feed-forward),
        exactly 0 for a loop of type 2 or more, as the tuner's."""
        if kind == "load":
            raise NotCovered("a user-defined drive has no load input")
        t, values = self._transients()
        p0, _, d0 = self._steady(kind)
        steady = 0.0 if kind == "step" or self._loop_type() > 1 else float(-self.c @ p0)
        return t, -values[kind], (lambda tt: float(-self.c @ expm(self.a * tt) @ d0)), steady

    def _loop_type(self) -> int:
        """Integrators of the open loop: 1 behind a velocity loop (x = ∫ẋ), else those of
        the drive's position per input (poles at s = 0 net of zeros there, a velocity
        output adding one); plus the position controller's (PI, PID)."""
        own = 1
        if not self.cascade:
            num, den = drive_transfer(self.plant["model"])
            own = (_zeros_at_origin(den) - _zeros_at_origin(num)
                   + (0 if self.position_output else 1))
        return own + (self.plant.get("position_controller", "p") != "p")

    def gain_margin(self) -> float:
        """1/|L| [1] where the open-loop phase first reaches −180°, the phase unwrapped from
        that of L·(jω)^n (n the loop's type, so it starts near 0° and not on the ±180° branch
        cut a type-2 loop's low-frequency phase sits on) minus n·90°; refined by brentq; +∞
        where the phase never reaches −180° on the grid (python-control's gm = inf)."""
        n = self._loop_type()
        grid = self._grid()
        phase = np.unwrap(np.angle(self._open(grid) * (1j * grid) ** n)) - n * math.pi / 2
        # the grid starts below the open loop's rounding-size poles (its integrators):
        # there a type-2 loop's phase is −180° to 1e-9 rad either side, not a crossing
        side = np.sign(np.where(np.abs(phase + math.pi) < 1e-9, 0.0, phase + math.pi))
        decided = np.flatnonzero(side)
        turns = np.flatnonzero(side[decided[:-1]] != side[decided[1:]])
        if turns.size == 0:
            return math.inf
        i, j = decided[turns[0]], decided[turns[0] + 1]

        def imag(u):
            lo = self._open(math.exp(u))[0]
            return lo.imag / abs(lo)

        omega = math.exp(brentq(imag, math.log(grid[i]), math.log(grid[j]), xtol=1e-14))
        return float(1.0 / abs(self._open(omega)[0]))

    def velocity_constant(self) -> float:
        """C_v = 1/e_ss [1/s] of the ramp without the feed-forward: lim s·L(s)."""
        if self._loop_type() > 1:
            raise NotCovered("a loop of type 2 or more has no finite velocity constant")
        return super().velocity_constant()

    def velocity_loop_poles(self) -> np.ndarray:
        """Poles [1/s] of the velocity loop alone (input v, output ẋ). An integrating drive
        with a position output carries its position integrator (a pole at s = 0 the
        velocity loop never feeds back) among the states: it is not one of them."""
        poles = np.linalg.eigvals(self._state_space("inner")[0])
        num, den = drive_transfer(self.plant["model"])
        if self.position_output and _zeros_at_origin(den) > _zeros_at_origin(num):
            poles = np.delete(poles, np.argmin(np.abs(poles)))
        return poles

    # -- the Model protocol ------------------------------------------------------------

    def sensitivity(self) -> float:
        """|G_v(0)·k_p·k_v| [1/s] (Bhatia Ch. IV eq 1 with the proportional gains), G_v the
        drive's velocity per input."""
        num, den = drive_transfer(self.plant["model"])
        num, den = np.trim_zeros(num, "f"), np.trim_zeros(den, "f")
        if self.position_output:
            if den[-1] != 0:
                raise NotCovered("the drive's velocity has a zero at s = 0")
            den = den[:-1]
        if den[-1] == 0 or num[-1] == 0:
            raise NotCovered("the drive's velocity per input has no finite DC gain")
        return float(abs(num[-1] / den[-1] * np.prod(list(self.gains.values()))))

    def measurement_tables(self) -> tuple[Phase, ...]:
        """The continuous loop's table, Bhatia's sensitivity (Ch. IV eq 1), and ζ, ω_n of a
        second-order loop."""
        (phase,) = super().measurement_tables()
        return (replace(phase, table={**phase.table, "sensitivity": SENSITIVITY,
                                      **PAIR_MEASUREMENTS}),)

    def measure(self, result: dict) -> list[dict]:
        """The continuous loop's entries, and the velocity loop's poles."""
        entries = super().measure(result)
        inner = (result.get("stability") or {}).get("inner_loop") or {}
        if inner.get("poles") and self.cascade:
            row = poles_entry(inner["poles"], self.velocity_loop_poles(), False)
            row["metric"] = "velocity_loop_poles"
            entries.append(row)
        return entries
