"""The machine spec: two or three axes, a shared interpolator and sampling period, a path.

A machine spec is JSON, untrusted and strict like a tuning spec (:mod:`feedtune.schema.spec`):
unknown keys, NaN, duplicate keys and wrong types are errors named by JSON pointer, and it
never names a file (a part program is given on the command line, ``--program``). Each axis
is any plant feedtune tunes (``feedtune plants``) with its own parameters and tunables;
the machine's ``sampling_period`` is every sampled axis' sampling period, and the period
at which every continuous axis is simulated exactly.

:func:`parse_machine` reads one and raises :class:`~feedtune.schema.spec.SpecError`.
"""

from __future__ import annotations

import math
from typing import Annotated, Literal, Union

from pydantic import (Field, NonNegativeFloat, PositiveFloat, ValidationError, field_validator,
                      model_validator)

from feedtune.schema.model import SpecModel
from feedtune.schema.spec import (_PLANT, PlantSpec, SpecError, TunableSpec, _merged,
                                  _schema_errors, _semantic_errors, _valid, json_type, load_json, tunable_box)

#: the shared tunable every sampled axis takes from the machine
SAMPLING_PERIOD = "sampling_period"
AXES = ("x", "y", "z")


class AxisSpec(SpecModel):
    """One axis: a plant with its controller (``feedtune plants``) and its tunables."""

    plant: PlantSpec
    tunables: dict[str, TunableSpec] = Field(
        default_factory=dict,
        description="This axis' tunables by name (not sampling_period: the machine's); a "
                    "free one is simulated at its 'initial', else its geometric mid-bound, "
                    "and tuned by `feedtune tune` [their units]")


class Axes(SpecModel):
    """The axes by name: x and y, optionally z."""

    x: AxisSpec
    y: AxisSpec
    z: AxisSpec | None = None

    def named(self) -> dict[str, AxisSpec]:
        """The axes given, by name, in x, y, z order."""
        return {name: axis for name in AXES if (axis := getattr(self, name)) is not None}


class LinePath(SpecModel):
    """A straight line from the origin."""

    type: Literal["line"]
    length: PositiveFloat = Field(description="Length [m]")
    angle: float = Field(0.0, ge=-2 * math.pi, le=2 * math.pi,
                         description="Direction from the x axis in the XY plane [rad]")
    feed: PositiveFloat = Field(description="Programmed feed [m/s]")


class CirclePath(SpecModel):
    """A full circle, counter-clockwise, started at (radius, 0) about the origin."""

    type: Literal["circle"]
    radius: PositiveFloat = Field(description="Radius [m]")
    feed: PositiveFloat = Field(description="Programmed feed [m/s]")
    turns: int = Field(1, ge=1, le=100, description="Times round [count]")


class CornerPath(SpecModel):
    """Two lines of equal length from the origin meeting at a corner."""

    type: Literal["corner"]
    length: PositiveFloat = Field(description="Length of each leg [m]")
    angle: float = Field(0.0, ge=-2 * math.pi, le=2 * math.pi,
                         description="Direction of the first leg from the x axis [rad]")
    turn: float = Field(math.pi / 2, gt=-math.pi, lt=math.pi,
                        description="Turn at the corner, counter-clockwise positive [rad] "
                                    "(π/2: a right angle to the left)")
    feed: PositiveFloat = Field(description="Programmed feed [m/s]")
    exact_stop: bool = Field(False, description="Stop at the corner (G9) [true/false]")


class BhatiaPath(SpecModel):
    """Bhatia 1971, Fig 38 (feedtune.machine.paths.bhatia_profile): the rapid traverse to
    A, the corner at B, the deceleration block CC' and the slow contouring blocks."""

    type: Literal["bhatia_fig38"]
    exact_stop_at_b: bool = Field(
        False, description="Stop at B (his 'special code' for a sharp corner: the overshoot "
                           "at B); false: the rounded corner [true/false]")


PathSpec = Annotated[Union[LinePath, CirclePath, CornerPath, BhatiaPath],
                     Field(discriminator="type")]


class InterpolatorSpec(SpecModel):
    """The shared interpolator (feedtune.machine.interpolate)."""

    period: PositiveFloat | None = Field(
        None, description="Interpolation period [s]: a whole multiple of the sampling "
                          "period, the reference linear between its points; omitted: the "
                          "sampling period (also when that is tuned)")
    max_acceleration: PositiveFloat | None = Field(
        None, description="Largest path acceleration and deceleration [m/s²]; omitted: "
                          "feed changes are steps")
    corner_tolerance: PositiveFloat | None = Field(
        None, description="Corner slow-down: the speed through a corner that turns by θ is "
                          "at most ε/(2τ sin(θ/2)), ε this [m] (Bhatia ch. 5); needs "
                          "max_acceleration; omitted: no corner slow-down")
    time_constant: PositiveFloat | None = Field(
        None, description="τ of the corner rule [s]; omitted: the least responsive axis' own "
                          "(the time its step response takes to reach 1 − 1/e)")
    max_normal_acceleration: PositiveFloat | None = Field(
        None, description="Largest normal (centripetal) acceleration on arcs [m/s²]: the feed "
                          "on an arc of radius R is at most √(a·R) (v²/R ≤ a), whatever the "
                          "program and the feed override ask; the arcs slowed are listed in "
                          "the metrics' 'interpolation' section; omitted: no limit")
    in_position: float | None = Field(
        None, ge=1e-9, le=1.0,
        description="In-position band [m] (e.g. one BLU; Bhatia's pulse weight .0002 in = "
                    "5.08e-6 m): at every exact stop (G9, G61, M0/M1, a rapid's ends, the "
                    "program's end) the next block waits until every axis' following error "
                    "is within it and stays there (Bhatia Fig 38: 'the execution of the next "
                    "block is started from rest'); the cycle time includes the waits; "
                    "omitted: the next block starts when the reference arrives")

    @model_validator(mode="after")
    def _corner_rule(self):
        if self.corner_tolerance is not None and self.max_acceleration is None:
            raise ValueError("corner_tolerance needs max_acceleration [m/s²] to slow down with")
        if self.time_constant is not None and self.corner_tolerance is None:
            raise ValueError("time_constant is the corner rule's: give corner_tolerance [m]")
        return self


class CrossCouplingSpec(SpecModel):
    """Koren's cross-coupled controller (1980): a PI on the estimated contour error whose
    output corrects the x and y references along the path's normal."""

    gain: NonNegativeFloat = Field(description="Proportional gain K_c on the contour-error "
                                               "estimate [1]")
    integral_time: PositiveFloat | None = Field(
        None, description="Integral time T_i [s]; omitted: a proportional controller")


class TuningSpec(SpecModel):
    """What `feedtune tune` does with a machine spec."""

    matched: bool = Field(
        False, description="Matched servos (Bhatia ch. 5): every axis gets the same velocity "
                           "constant C_v [1/s], one tuned variable; each axis must then have "
                           "exactly one free tunable")
    contour_tolerance: PositiveFloat | None = Field(
        None, description="Largest contour error allowed over the program [m]; required when "
                          "feed_override is free")
    objective: Literal["cycle_time", "max_contour_error", "rms_contour_error"] = Field(
        "cycle_time", description="cycle_time: the shortest cycle (feed_override free) within "
                                  "contour_tolerance; max/rms_contour_error: the smallest error "
                                  "at the given feed")
    max_evaluations: int = Field(400, ge=1, le=100_000,
                                 description="Largest number of simulations [count]")


class MachineSpec(SpecModel):
    """A machine: its axes, sampling period, interpolator, path and tuning."""

    name: str = Field(min_length=1, max_length=200, description="Name [text]")
    description: str = Field("", max_length=10_000, description="Free text for people")
    axes: Axes
    sampling_period: TunableSpec = Field(
        description="Sampling period T of every axis [s]: {'value': ...} or {'min', 'max'}")
    feed_override: TunableSpec = Field(
        default_factory=lambda: TunableSpec(value=1.0),
        description="Factor on every programmed feed [1] (the control's feed override); "
                    "free: tuned for the shortest cycle")
    interpolator: InterpolatorSpec = Field(default_factory=InterpolatorSpec)
    path: PathSpec | None = Field(
        None, description="A built-in path; omitted: a part program given on the command "
                          "line (--program), which also replaces this one")
    cross_coupling: CrossCouplingSpec | None = Field(
        None, description="Koren's cross-coupled controller; omitted: independent axes")
    tuning: TuningSpec = Field(default_factory=TuningSpec)

    @field_validator("sampling_period", "feed_override")
    @classmethod
    def _bounded(cls, tunable: TunableSpec) -> TunableSpec:
        if tunable.value is None and (tunable.min is None or tunable.max is None):
            raise ValueError("give 'value', or 'min' and 'max' (no plant supplies defaults "
                             "for the machine's own tunables)")
        return tunable

    @model_validator(mode="after")
    def _consistent(self):
        if self.feed_override.value is None and self.tuning.contour_tolerance is None:
            raise ValueError("a free feed_override needs tuning.contour_tolerance [m]")
        return self


def _box(spec: TunableSpec) -> tuple[float, float]:
    if spec.value is not None:
        return spec.value, spec.value
    return spec.min, spec.max


def nominal(spec: TunableSpec, lower: float, upper: float) -> float:
    """What a tunable is simulated at: its value, else ``initial``, else √(min·max)."""
    if spec.value is not None:
        return spec.value
    if spec.initial is not None:
        return spec.initial
    return math.sqrt(lower * upper)


def parse_machine(data: bytes | str | dict) -> MachineSpec:
    """Validate a machine spec (JSON text, bytes or a parsed dict).

    Raises
    ------
    SpecError
        One (JSON pointer, message) per problem: the schema's, and per axis the plant's
        (tunables, bounds, its loop) as ``feedtune validate`` finds them.
    """
    raw = data if isinstance(data, dict) else load_json(data)
    if not isinstance(raw, dict):
        raise SpecError([("", f"a machine spec is a JSON object, not {json_type(raw)}")])
    errors, spec = [], None
    try:
        spec = MachineSpec.model_validate(raw, strict=True)
    except ValidationError as exc:
        errors = _schema_errors(exc, raw)
    errors = _merged(errors, _axis_errors(raw))
    if spec is not None and not errors:
        errors += _machine_errors(spec)
    if errors:
        raise SpecError(errors)
    return spec


def _axis_errors(raw: dict) -> list[tuple[str, str]]:
    """Each axis checked as a tuning spec's plant and tunables are, pointers under it."""
    from feedtune.plants import plant_for

    axes = raw.get("axes")
    period = raw.get(SAMPLING_PERIOD)
    errors = []
    for name in AXES:
        axis = axes.get(name) if isinstance(axes, dict) else None
        if not isinstance(axis, dict):
            continue
        where = f"/axes/{name}"
        params = _valid(_PLANT, axis.get("plant"))
        tunables = axis.get("tunables", {})
        if isinstance(tunables, dict) and SAMPLING_PERIOD in tunables:
            errors.append((f"{where}/tunables/{SAMPLING_PERIOD}",
                           "the machine's sampling_period sets it for every axis"))
            continue
        if params is None:
            continue
        plant = plant_for(params)
        if plant.tunables().get("reference_interval") is not None:
            errors.append((f"{where}/plant/interpolation",
                           "the machine's interpolator feeds the axes: give 'none'"))
            continue
        given = dict(tunables) if isinstance(tunables, dict) else tunables
        if isinstance(given, dict) and SAMPLING_PERIOD in plant.tunables():
            given[SAMPLING_PERIOD] = period if isinstance(period, dict) else {}
        for pointer, message in _semantic_errors({"plant": axis.get("plant"),
                                                  "tunables": given}):
            pointer = pointer.replace(f"/tunables/{SAMPLING_PERIOD}", f"/{SAMPLING_PERIOD}")
            errors.append((pointer if pointer.startswith(f"/{SAMPLING_PERIOD}")
                           else where + pointer, message))
    return errors


def _machine_errors(spec: MachineSpec) -> list[tuple[str, str]]:
    """What needs the whole machine: a linear loop on every axis, the interpolation period
    a whole multiple of the sampling period, matched axes with one free tunable each."""
    from feedtune.loops.export import closed_loop_state_space
    from feedtune.plants import plant_for

    errors = []
    low, high = _box(spec.sampling_period)
    interp = spec.interpolator.period
    if interp is not None:
        if spec.sampling_period.value is None:
            errors.append(("/interpolator/period", "with sampling_period tuned, the "
                                                   "interpolation period follows it: omit it"))
        elif not _whole(interp / low):
            errors.append(("/interpolator/period",
                           f"{interp} s is not a whole multiple of the sampling period {low} s"))
    if spec.interpolator.in_position is not None and spec.cross_coupling is not None:
        errors.append(("/interpolator/in_position",
                       "the in-position wait is computed for independent axes (their "
                       "errors add up piece by piece); not with cross_coupling"))
    for name, axis in spec.axes.named().items():
        plant = plant_for(axis.plant)
        box, _, _ = tunable_box(axis.tunables, plant.tunables())
        if SAMPLING_PERIOD in box:
            box[SAMPLING_PERIOD] = (low, high)
        values = {n: nominal(axis.tunables.get(n, TunableSpec()), lo, hi)
                  for n, (lo, hi) in box.items()}
        if SAMPLING_PERIOD in values:
            values[SAMPLING_PERIOD] = nominal(spec.sampling_period, low, high)
        try:
            closed_loop_state_space(plant.loop(values, box))
        except TypeError as exc:
            errors.append((f"/axes/{name}/plant", f"{exc}: no closed loop to simulate"))
        if spec.tuning.matched:
            free = [n for n, (lo, hi) in box.items() if lo != hi and n != SAMPLING_PERIOD]
            if len(free) != 1:
                errors.append((f"/axes/{name}/tunables",
                               f"matched axes need exactly one free tunable per axis (the one "
                               f"that sets C_v); free here: {', '.join(free) or 'none'}"))
    return errors


def _whole(ratio: float) -> bool:
    return abs(ratio - round(ratio)) <= 1e-9 * max(1.0, ratio) and round(ratio) >= 1

