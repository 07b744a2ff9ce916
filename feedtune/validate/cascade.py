"""Bhatia's two-loop cascade (Fig 18/33) as a state-space model of numbers, for the validator.

A drive is given as a state-space block from armature/valve volts u [V] and load torque
T_L [N·m] to shaft velocity θ̇ [rad/s] (written from the drive's physics by its module);
compensators are state-space blocks of their transfer functions (Bhatia Table 5, App. C).
The loops are closed by writing every signal of Fig 18 as a linear map of the states and
inputs,

    e_p = θ_i − θ,  v = K'_p·Gc_p(e_p),  e_v = v − θ̇,  u = K'_v·Gc_v(e_v),  θ' = θ̇,

not from the closed-loop polynomial the tuner uses; the metrics are measured by
:class:`feedtune.validate.continuous.ContinuousModel`.

References
----------
S. Bhatia, "Feed drive design for numerically controlled machine tools", M.S. thesis,
University of Missouri–Rolla, 1971, Ch. IV (Fig 18, eq 1), Table 5, App. C.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from feedtune.validate.continuous import SENSITIVITY, Block, ContinuousModel, siso
from feedtune.validate.entries import poles_entry
from feedtune.validate.measurements import Phase
from feedtune.validate.model import NotCovered


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



class CascadeModel(ContinuousModel):
    """Position loop around a velocity loop around ``drive`` (inputs u, T_L → θ̇)."""

    def __init__(self, drive: Block, position_gain: float, velocity_gain: float,
                 position_compensator: Block, velocity_compensator: Block, has_load: bool):
        if np.any(drive.d):
            raise ValueError("the drive must be strictly proper (no direct feedthrough)")
        self.drive, self.kp, self.kv = drive, position_gain, velocity_gain
        self.cp, self.cv = position_compensator, velocity_compensator
        a_open, b_open, c = self._closed(open_at_position=True)
        super().__init__(self._closed(), (a_open, b_open[:, :1], c), has_load)

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

    def sensitivity(self) -> float:
        """|G(0) K'_v K'_p| [1/s], G(0) = −C_d A_d⁻¹ B_d the drive's DC velocity per volt
        (Bhatia Ch. IV eq 1)."""
        g0 = -self.drive.c[0] @ np.linalg.solve(self.drive.a, self.drive.b[:, 0])
        return float(abs(g0 * self.kv * self.kp))

    # -- frequency-domain metrics ------------------------------------------------------

    def measurement_tables(self) -> tuple[Phase, ...]:
        """The continuous loop's table and Bhatia's sensitivity (Ch. IV eq 1)."""
        (phase,) = super().measurement_tables()
        return (replace(phase, table={**phase.table, "sensitivity": SENSITIVITY}),)

    def circle_test(self, radius, feed):
        raise NotCovered("a rotary axis: no two-axis circle test")

    def measure(self, result: dict) -> list[dict]:
        """The continuous loop's entries, and the velocity loop's poles."""
        entries = super().measure(result)
        inner = (result.get("stability") or {}).get("inner_loop") or {}
        if inner.get("poles"):
            row = poles_entry(inner["poles"], np.linalg.eigvals(self._inner()), False)
            row["metric"] = "velocity_loop_poles"
            entries.append(row)
        return entries
