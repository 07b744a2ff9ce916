"""Tuning a machine on a program: per-axis gains (free or matched), sampling period and
feed override, by searching the exact simulation (:func:`feedtune.machine.run.run`).

The objective is the simulated program itself (its largest contour error, its cycle
time), a non-smooth function of the gains (the sample and corner where the largest error
sits change with them) with no symbolic form in the tuner's Loop interface, so the search
is scipy's: bounded Brent for one variable, Nelder–Mead in the logarithms of the
variables otherwise (docs/design.md, "Multi-axis contouring"). With a free feed override
and a contour tolerance, each point's feed is the largest that holds the tolerance,
found by Brent's root finder on ln(feed) (the error grows with the feed), and the
objective is the cycle time at that feed.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from scipy.optimize import brentq, minimize, minimize_scalar

from feedtune.expr import to_float
from feedtune.machine.run import (Axes, Setting, axis_box, axis_loop, commanded_samples,
                                  nominal_setting, prepare_axes, run)
from feedtune.machine.simulate import UnstableAxis
from feedtune.machine.spec import SAMPLING_PERIOD, MachineSpec
from feedtune.schema.status import INFEASIBLE, ITERATION_LIMIT, OPTIMAL

#: a point that misses the tolerance at the lowest feed scores this plus its excess [1]
INFEASIBLE = 1e6
#: relative accuracy of the feed found for a point [1]
FEED_RTOL = 1e-3
#: interpolated references kept by the tuner (the oldest dropped) [count]
KEPT_REFERENCES = 4


class _Budget(Exception):
    """The spec's max_evaluations is spent."""


class MachineTuner:
    """The search over a machine's free variables on one path (see the module)."""

    def __init__(self, spec: MachineSpec, path):
        self.spec, self.path = spec, path
        self.start = nominal_setting(spec)
        self.evaluations = 0
        self.budget = spec.tuning.max_evaluations
        self.free = [(axis, name, lo, hi) for axis in spec.axes.named()
                     for name, (lo, hi) in axis_box(spec, axis).items()
                     if lo != hi and name != SAMPLING_PERIOD]
        t = spec.sampling_period
        self.period_box = None if t.value is not None else (t.min, t.max)
        f = spec.feed_override
        self.feed_box = None if f.value is not None else (f.min, f.max)
        self.cv_box = self._cv_box() if spec.tuning.matched else None
        self.last_feed = math.log(self.start.feed_override)
        self._axes: dict = {}
        self._samples: dict = {}
        self.feeds: dict = {}  # the feed found at each point searched

    # -- the variables ---------------------------------------------------------------------
    def bounds(self) -> list[tuple[float, float]]:
        """ln-bounds of the search variables: C_v (matched) or every free tunable, then T."""
        boxes = [self.cv_box] if self.cv_box else [(lo, hi) for _, _, lo, hi in self.free]
        if self.period_box:
            boxes.append(self.period_box)
        return [(math.log(lo), math.log(hi)) for lo, hi in boxes]

    def initial(self) -> list[float]:
        if self.cv_box:
            values = [math.sqrt(self.cv_box[0] * self.cv_box[1])]
        else:
            values = [self.start.values[a][n] for a, n, _, _ in self.free]
        if self.period_box:
            values.append(self.start.period)
        return [math.log(v) for v in values]

    def setting(self, z) -> Setting:
        values = {axis: dict(v) for axis, v in self.start.values.items()}
        z = list(np.exp(z))
        period = z.pop() if self.period_box else self.start.period
        if self.cv_box:
            target = z[0]
            for axis, name, lo, hi in self.free:
                values[axis][name] = self._matching(axis, name, lo, hi, target, period)
        else:
            for (axis, name, _, _), value in zip(self.free, z):
                values[axis][name] = value
        return replace(self.start, values=values, period=period)

    def _velocity_constant(self, axis, name, value, period) -> float:
        return self._cv(axis, dict(self.start.values[axis], **{name: value}), period)

    def _cv(self, axis, values, period) -> float:
        """C_v [1/s] of axis ``axis`` at ``values``."""
        return to_float(axis_loop(self.spec, axis, values, period).velocity_constant)

    def _cv_box(self):
        lows, highs = [], []
        for axis, name, lo, hi in self.free:
            lows.append(self._velocity_constant(axis, name, lo, self.start.period))
            highs.append(self._velocity_constant(axis, name, hi, self.start.period))
        return max(lows), min(highs)

    def _matching(self, axis, name, lo, hi, target, period) -> float:
        """The axis' free tunable whose C_v is ``target`` [1/s] (Bhatia's matched servos)."""
        def gap(u):
            return math.log(self._velocity_constant(axis, name, math.exp(u), period) / target)

        a, b = math.log(lo), math.log(hi)
        if gap(a) >= 0:
            return lo
        if gap(b) <= 0:
            return hi
        return math.exp(brentq(gap, a, b, xtol=1e-12))

    # -- the objective ---------------------------------------------------------------------
    def axes(self, setting: Setting) -> Axes | None:
        """:func:`prepare_axes` at ``setting``'s gains and period (None: unstable), kept
        for the setting's other feeds: the feed search changes only the reference."""
        key = (tuple((axis, tuple(sorted(values.items())))
                     for axis, values in sorted(setting.values.items())), setting.period)
        if key not in self._axes:
            try:
                self._axes = {key: prepare_axes(self.spec, setting)}  # the last gains only
            except UnstableAxis:
                self._axes = {key: None}
        return self._axes[key]

    def simulate(self, setting: Setting) -> dict | None:
        """Metrics at ``setting``, or None for an unstable loop."""
        if self.evaluations >= self.budget:
            raise _Budget
        self.evaluations += 1
        axes = self.axes(setting)
        if axes is None:
            return None
        # the search reads the largest error (the RMS only when it is the objective) and
        # the cycle time; the answer all
        final = math.isinf(self.budget)
        return run(self.spec, self.path, setting, detail=final, axes=axes,
                   rms=final or self.spec.tuning.objective == "rms_contour_error",
                   samples=self.samples(setting, axes)).metrics

    def samples(self, setting: Setting, axes: Axes):
        """:func:`commanded_samples` at ``setting``, kept for the next points: a new point
        of the gains starts its feed search at the last point's feed. With an in-position
        wait the holds depend on the gains, so they are part of the key."""
        key = (setting.feed_override, setting.period, axes.corner_time_constant)
        if self.spec.interpolator.in_position is not None:
            key += tuple((name, tuple(sorted(values.items())))
                         for name, values in sorted(setting.values.items()))
        if key not in self._samples:
            if len(self._samples) >= KEPT_REFERENCES:
                del self._samples[next(iter(self._samples))]
            self._samples[key] = commanded_samples(self.spec, self.path, setting, axes)
        return self._samples[key]

    def score(self, z) -> float:
        setting = self.setting(z)
        tuning = self.spec.tuning
        if self.feed_box is None:
            metrics = self.simulate(setting)
            if metrics is None:
                return 2 * INFEASIBLE
            value = metrics[{"cycle_time": "max_contour_error"}.get(tuning.objective,
                                                                    tuning.objective)]
            if tuning.contour_tolerance is not None:
                excess = metrics["max_contour_error"] / tuning.contour_tolerance - 1
                if excess > 0:
                    return INFEASIBLE + excess
            return value
        feed, metrics = self.fastest(setting)
        self.feeds[tuple(z)] = feed
        if metrics is None:
            return 2 * INFEASIBLE
        excess = metrics["max_contour_error"] / tuning.contour_tolerance - 1
        return INFEASIBLE + excess if excess > 0 else metrics["cycle_time"]

    def fastest(self, setting: Setting):
        """(the largest feed override within the tolerance, its metrics); the lowest
        feed's when even that misses the tolerance.

        From the last point's feed, steps in ln(feed) by −ln(error/tolerance) (the error
        grows about in proportion to the feed: the lags V/C_v and the corner errors do)
        until the tolerance is bracketed, then Brent to :data:`FEED_RTOL`."""
        tol = self.spec.tuning.contour_tolerance
        low, high = (math.log(v) for v in self.feed_box)
        found = {}

        def gap(u):
            # Brent starts from the bracket's ends, already simulated: not again
            metrics = found[u] if u in found else self.simulate(
                replace(setting, feed_override=math.exp(u)))
            found[u] = metrics
            return math.inf if metrics is None else math.log(metrics["max_contour_error"] / tol)

        a = min(max(self.last_feed, low), high)
        fa = gap(a)
        for _ in range(8):
            b = min(max(a - (fa if math.isfinite(fa) else 1.0), low), high)
            if b == a:
                break
            fb = gap(b)
            if (fa > 0) != (fb > 0):
                u = brentq(gap, min(a, b), max(a, b), xtol=FEED_RTOL)
                ok = [v for v, m in found.items() if m is not None and gap_of(m, tol) <= 0]
                best = max(ok) if ok else u
                self.last_feed = best
                return math.exp(best), found[best]
            a, fa = b, fb
        self.last_feed = a
        return math.exp(a), found[a]

    # -- the search ------------------------------------------------------------------------
    def solve(self) -> dict:
        """Search, then the result document (JSON-ready, SI units)."""
        bounds = self.bounds()
        status = OPTIMAL
        best = {"z": self.initial(), "f": math.inf}

        def objective(z):
            z = np.clip(z, [b[0] for b in bounds], [b[1] for b in bounds])
            f = self.score(z)
            if f < best["f"]:
                best.update(z=list(z), f=f)
            return f

        try:
            if len(bounds) == 1:
                # with a free feed the objective is resolved to FEED_RTOL in feed (so in
                # cycle time): finer steps of the variable would chase that resolution
                minimize_scalar(lambda u: objective([u]), bounds=bounds[0], method="bounded",
                                options={"xatol": FEED_RTOL if self.feed_box else 1e-4})
            elif bounds:
                minimize(objective, self.initial(), method="Nelder-Mead", bounds=bounds,
                         options={"xatol": 1e-4, "fatol": 0.0})
            else:
                objective([])
        except _Budget:
            status = ITERATION_LIMIT  # the evaluation budget is spent
        if best["f"] >= INFEASIBLE:
            status = INFEASIBLE
        setting = self.setting(best["z"])
        self.budget = math.inf  # the answer's own runs are outside the budget
        if self.feed_box is not None:
            feed = self.feeds.get(tuple(best["z"]))
            setting = replace(setting, feed_override=feed if feed is not None
                              else self.fastest(setting)[0])
        self.answer = setting
        final = self.simulate(setting)
        return {"name": self.spec.name, "kind": "machine", "status": status,
                "success": status != INFEASIBLE and final is not None,
                "tuned": {axis: values for axis, values in setting.values.items()},
                "sampling_period": setting.period, "feed_override": setting.feed_override,
                "velocity_constants": {axis: self._cv(axis, values, setting.period)
                                       for axis, values in setting.values.items()},
                "metrics": final, "evaluations": self.evaluations}


def gap_of(metrics: dict, tolerance: float) -> float:
    """ln(largest contour error / tolerance) [1]: ≤ 0 within the tolerance."""
    return math.log(metrics["max_contour_error"] / tolerance)


def tune_machine(spec: MachineSpec, path) -> dict:
    """Tune ``spec`` on ``path``: :class:`MachineTuner`'s search and its result."""
    return MachineTuner(spec, path).solve()
