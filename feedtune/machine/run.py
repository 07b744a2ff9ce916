"""One machine over one path: axes' loops → interpolated reference → exact simulation →
contour metrics. What ``feedtune simulate`` runs, and what the machine tuner evaluates.

Each axis' loop is built by its plant from numbers (``plant.loop(values, box)``, the loop
``feedtune tune`` tunes), its closed loop taken as a state space
(:func:`~feedtune.loops.export.closed_loop_state_space`) and made discrete at the
sampling period (:func:`~feedtune.machine.simulate.discretise`). A rotary drive's loop
(Bhatia's hydraulic and Ward-Leonard drives, positions in rad) maps a reference to a
position in the same unit with unit DC gain; the lead screw scales both alike, so the
closed loop is the axis' in metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from feedtune.expr import to_float
from feedtune.loops.export import closed_loop_state_space
from feedtune.loops.protocols import Capability
from feedtune.machine.contour import contour_metrics, step_settling_time
from feedtune.machine.inposition import settled_reference
from feedtune.machine.interpolate import interpolate
from feedtune.machine.path import Path, SegmentTable
from feedtune.machine.simulate import (AxisModel, CrossCoupling, discretise, run_out_samples,
                                       simulate_coupled, simulate_independent)
from feedtune.machine.spec import SAMPLING_PERIOD, MachineSpec, nominal
from feedtune.plants import plant_for
from feedtune.schema.spec import TunableSpec, tunable_box

#: the first-order time constant of an axis is when its step response reaches 1 − 1/e
RISE = 1 - math.exp(-1)


@dataclass(frozen=True)
class Setting:
    """What a machine runs at: each axis' tunables, the sampling period [s], the feed
    override [1] and the cross-coupled controller (or None)."""

    values: dict[str, dict[str, float]]
    period: float
    feed_override: float
    cross_coupling: CrossCoupling | None


@dataclass(frozen=True)
class MachineRun:
    """A simulated program: samples (the program and its run-out) and its metrics.

    Attributes
    ----------
    axes : tuple of str
    time : ndarray (N,) [s]
    commanded, actual : ndarray (N, 3) [m]
    arc_length : ndarray (N,) [m], the commanded arc length
    segment : ndarray of int (N,)
    tangent : ndarray (N, 3) or None
        The path's unit tangent at the commanded point (None: not computed, see
        :func:`run`).
    contour_error : ndarray (N,) [m] or None
        The tool's distance from the path at each sample (None: not computed).
    metrics : dict
        :func:`~feedtune.machine.contour.contour_metrics`, plus ``stable`` true.
    """

    path: Path
    axes: tuple[str, ...]
    time: np.ndarray
    commanded: np.ndarray
    actual: np.ndarray
    arc_length: np.ndarray
    segment: np.ndarray
    tangent: np.ndarray | None
    contour_error: np.ndarray | None
    metrics: dict


def nominal_setting(spec: MachineSpec) -> Setting:
    """Every tunable at its value, ``initial`` or geometric mid-bound."""
    values = {}
    for name, axis in spec.axes.named().items():
        box = axis_box(spec, name)
        values[name] = {n: nominal(axis.tunables.get(n, TunableSpec()), lo, hi)
                        for n, (lo, hi) in box.items() if n != SAMPLING_PERIOD}
    low, high = _bounds(spec.sampling_period)
    f_low, f_high = _bounds(spec.feed_override)
    ccc = spec.cross_coupling
    return Setting(values, nominal(spec.sampling_period, low, high),
                   nominal(spec.feed_override, f_low, f_high),
                   None if ccc is None else CrossCoupling(ccc.gain, ccc.integral_time))


def _bounds(tunable: TunableSpec) -> tuple[float, float]:
    return (tunable.value, tunable.value) if tunable.value is not None else (tunable.min,
                                                                             tunable.max)


def axis_box(spec: MachineSpec, name: str) -> dict[str, tuple[float, float]]:
    """(min, max) of each tunable of axis ``name`` [their units], the machine's sampling
    period's for ``sampling_period``."""
    axis = spec.axes.named()[name]
    box, _, _ = tunable_box(axis.tunables, plant_for(axis.plant).tunables())
    if SAMPLING_PERIOD in box:
        box[SAMPLING_PERIOD] = _bounds(spec.sampling_period)
    return box


def axis_loop(spec: MachineSpec, name: str, values: dict[str, float], period: float):
    """Axis ``name``'s feedtune Loop of numbers at ``values`` and sampling ``period``."""
    plant = plant_for(spec.axes.named()[name].plant)
    box = axis_box(spec, name)
    given = dict(values)
    if SAMPLING_PERIOD in box:
        given[SAMPLING_PERIOD] = period
    return plant.loop(given, box)


def axis_models(spec: MachineSpec, setting: Setting) -> list[AxisModel]:
    """Every axis' discrete closed loop at the setting's sampling period."""
    return [model for model, _ in _axes(spec, setting)]


def _axes(spec: MachineSpec, setting: Setting) -> list[tuple[AxisModel, float]]:
    """(discrete closed loop, velocity lag 1/C_v [s], 0 where the loop has no C_v) of
    every axis."""
    out = []
    for name in spec.axes.named():
        loop = axis_loop(spec, name, setting.values[name], setting.period)
        a, b, c, d, dt = closed_loop_state_space(loop)
        lag = (1 / to_float(loop.velocity_constant)
               if loop.offers(Capability.VELOCITY_CONSTANT) else 0.0)
        out.append((discretise(a, b, c, d, dt, setting.period), lag))
    return out


def rise_time(model: AxisModel, samples: int) -> float:
    """The time [s] an axis' step response first reaches 1 − 1/e (its first-order time
    constant, Bhatia's τ of a slide)."""
    from feedtune.machine.simulate import simulate_lti

    y = simulate_lti(model.phi, model.gamma[:, :2], model.c, np.array([model.d, 0.0]),
                     np.ones((samples, 2)))
    reached = np.flatnonzero(y >= RISE)
    return float(reached[0] * model.period) if reached.size else float(samples * model.period)


@dataclass(frozen=True)
class Axes:
    """What a setting's gains and sampling period fix, whatever the feed: each axis'
    discrete closed loop, its velocity lag 1/C_v [s] (0 without a C_v), its 2 % step
    settling time [s], and the corner rule's time constant τ [s] (None without the rule)."""

    models: list[AxisModel]
    lags: list[float]
    settling: list[float]
    corner_time_constant: float | None


def prepare_axes(spec: MachineSpec, setting: Setting) -> Axes:
    """The :class:`Axes` of ``spec`` at ``setting`` (a tuner keeps them while only the
    feed changes).

    Raises
    ------
    UnstableAxis
        An axis' closed loop is unstable at the setting.
    """
    axes = _axes(spec, setting)
    models = [model for model, _ in axes]
    probe = run_out_samples(models, 10**6)
    settling = [step_settling_time(m, probe) for m in models]
    interp = spec.interpolator
    tau = None
    if interp.corner_tolerance is not None:
        tau = interp.time_constant or max(rise_time(m, probe) for m in models)
    return Axes(models, [lag for _, lag in axes], settling, tau)


def commanded_samples(spec: MachineSpec, path: Path, setting: Setting, axes: Axes):
    """The interpolated reference at the sampling instants, before the run-out: time [s]
    (N,), position [m] (N, 3), arc length [m] (N,), segment (N,), and the interpolator's
    summary (dict). It depends on the setting's feed override and period and on the corner
    rule's τ only, not on the gains, unless the interpolator waits in position at exact
    stops (``interpolator.in_position``): its holds follow from the axes' loops.

    Raises
    ------
    ValueError
        The path moves z on a machine without a z axis, or the interpolator refuses it.
    """
    interp = spec.interpolator
    ratio = round(interp.period / setting.period) if interp.period else 1
    options = dict(period=ratio * setting.period, max_acceleration=interp.max_acceleration,
                   corner_tolerance=interp.corner_tolerance,
                   time_constant=axes.corner_time_constant,
                   feed_override=setting.feed_override,
                   max_normal_acceleration=interp.max_normal_acceleration)
    if interp.in_position is None:
        reference = interpolate(path, **options)
    else:
        reference = settled_reference(axes.models, path, band=interp.in_position,
                                      ratio=ratio, **options)
    if "z" not in spec.axes.named() and np.any(reference.position[:, 2]
                                               != reference.position[0, 2]):
        raise ValueError("the path moves z; the machine has no z axis")
    sampled = reference.resampled(ratio)
    return (sampled.time, sampled.position, sampled.arc_length, sampled.segment,
            reference.summary)


def run(spec: MachineSpec, path: Path, setting: Setting | None = None,
        detail: bool = True, *, axes: Axes | None = None, rms: bool = True,
        samples: tuple | None = None) -> MachineRun:
    """Simulate ``path`` on the machine at ``setting`` (default :func:`nominal_setting`);
    ``detail`` False leaves out the corners, stops and deceleration blocks, and ``rms``
    False (with ``detail`` False) the RMS contour error too: the largest is then found
    without measuring every sample (:func:`~feedtune.machine.contour.
    largest_contour_distance`), and ``contour_error`` and ``tangent`` are None (the
    tangent is computed only for the report and the cross-coupled controller).
    ``axes``: :func:`prepare_axes` of this setting, and ``samples``:
    :func:`commanded_samples` of it, when the caller has them.

    Raises
    ------
    UnstableAxis
        An axis' closed loop is unstable at the setting.
    ValueError
        The path moves z on a machine without a z axis, or the interpolator refuses it.
    """
    setting = setting or nominal_setting(spec)
    names = tuple(spec.axes.named())
    axes = axes or prepare_axes(spec, setting)
    models = axes.models
    time, position, arc, segment, summary = (samples
                                             or commanded_samples(spec, path, setting, axes))
    program_end = float(time[-1])
    extra = run_out_samples(models, len(time))
    time = np.concatenate([time, time[-1] + setting.period * np.arange(1, extra + 1)])
    position = np.vstack([position, np.repeat(position[-1:], extra, axis=0)])
    arc = np.concatenate([arc, np.full(extra, arc[-1])])
    segment = np.concatenate([segment, np.full(extra, segment[-1])])
    commanded = position[:, :len(names)]
    coupled = setting.cross_coupling is not None and setting.cross_coupling.gain != 0
    tangent = None
    if coupled or detail or rms:
        tangent, curvature = path_direction(SegmentTable.of(path), arc, segment)
    if coupled:
        actual = simulate_coupled(models, commanded, tangent, curvature,
                                  setting.cross_coupling)
    else:
        actual = simulate_independent(models, commanded)
    full = np.zeros_like(position)
    full[:, :len(names)] = actual
    if len(names) < 3:
        full[:, 2] = position[:, 2]
    metrics, error = contour_metrics(path, time, position, full, arc, segment, program_end,
                                     axes.settling, max(axes.lags), names,
                                     setting.feed_override, detail, rms)
    if summary:
        metrics["interpolation"] = summary
    return MachineRun(path, names, time, position, full, arc, segment, tangent, error,
                      metrics)


def path_direction(table: SegmentTable, arc: np.ndarray, segment: np.ndarray):
    """Unit tangent (N, 3) and signed curvature [1/m] (N,) of the path at each sample."""
    u = np.clip((arc - table.begin[segment]) / np.where(table.length[segment] > 0,
                                                         table.length[segment], 1.0), 0, 1)
    d = table.end[segment] - table.start[segment]
    norm = np.linalg.norm(d, axis=1)
    tangent = d / np.where(norm > 0, norm, 1.0)[:, None]
    is_arc = table.arc[segment]
    angle = table.angle[segment] + u * table.sweep[segment]
    turn = np.sign(table.sweep[segment])
    tangent[is_arc] = np.column_stack([-turn * np.sin(angle), turn * np.cos(angle),
                                       np.zeros_like(angle)])[is_arc]
    radius = np.where(is_arc, table.radius[segment], np.inf)
    return tangent, np.where(is_arc, turn / radius, 0.0)


def builtin_path(spec) -> Path:
    """The path of a spec's built-in ``path`` section (lengths [m], feeds [m/s]), from
    :mod:`feedtune.machine.paths`."""
    from feedtune.machine import paths

    kind = spec.type
    if kind == "line":
        return paths.line(spec.length, spec.angle, feed=spec.feed)
    if kind == "circle":
        return Path(paths.circle(spec.radius, feed=spec.feed).segments * spec.turns)
    if kind == "corner":
        return paths.corner(spec.length, spec.angle, feed=spec.feed, turn=spec.turn,
                            exact_stop=spec.exact_stop)
    return paths.bhatia_profile(exact_stop_at_b=spec.exact_stop_at_b)

