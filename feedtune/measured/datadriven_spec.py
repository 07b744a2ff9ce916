"""The ``convex`` technique: a spec whose plant is ``frequency_response_data``, read,
checked and tuned by :func:`feedtune.measured.datadriven.design` into the same
:class:`~feedtune.schema.result.TuneResult` every other tuning gives.

Such a spec has the usual shape (name, plant, tunables, objective, constraints, solver),
with what the convex design can hold:

* objective: one term, ``bandwidth`` or ``crossover_frequency`` with ``goal: maximize``, or
  ``weighted_sensitivity`` (max |W S|) with ``goal: minimize``;
* constraints: ``m_peak``, ``sensitivity_peak`` and/or ``weighted_sensitivity`` with
  ``max`` [1], each at most once, held at every measured frequency of every set;
* sensitivity_weight: W(s) = (s/M + ω_B)/(s + ω_B A) of ``weighted_sensitivity``, needed
  where it is used;
* solver: ``{"method": "convex", "max_iter": …, "tol": …, "time_limit": …}``.

The metrics are the model metrics' definitions on the measured frequencies (the loop
exists only there): M_peak = max |T| (T(0) = 1: the loop has an integrator), M_s = max
|S|, the bandwidth and crossover where |T| falls below 1/√2 and |L| below 1 (interpolated
between neighbouring points), max |W S| given a weight, each the worst over the sets, and
per set as ``name(set=…)``.

References
----------
A. Karimi, C. Kammer, "A data-driven approach to robust control of multivariable systems
by convex optimization", Automatica 85 (2017) 227–233.
"""

from __future__ import annotations

import hashlib
import json
import math
from typing import Literal, Sequence

from pydantic import (Field, PositiveFloat, PositiveInt, ValidationError, field_validator,
                      model_validator)

from feedtune.plants.frequency_response_data import (FrequencyResponseData,
                                                     FrequencyResponseDataParams)
from feedtune.schema.labels import metric_label
from feedtune.schema.model import SpecModel
from feedtune.schema.spec import _CONTROL, TunableSpec
from feedtune.schema.status import ERROR, OPTIMAL

#: the model metrics' units (feedtune metrics), for the metrics the data give
UNITS = {"m_peak": "1", "sensitivity_peak": "1", "bandwidth": "rad/s",
         "crossover_frequency": "rad/s", "phase_margin": "deg", "weighted_sensitivity": "1"}
#: what the technique does with each: widen it (objective), bound it (constraint), or
#: report it; ``feedtune metrics`` lists them under TECHNIQUE
ROLES = {"bandwidth": "objective", "crossover_frequency": "objective", "m_peak": "constraint",
         "sensitivity_peak": "constraint", "phase_margin": "reported",
         "weighted_sensitivity": "objective or constraint"}
#: metrics only the measured-data technique has (no model metric of that name): ``feedtune
#: metrics`` lists them from here
DATA_METRICS = {"weighted_sensitivity": {
    "unit": "1",
    "description": "max |W(jω) S(jω)| over the measured frequencies of every set, S = 1/(1 + L), "
                   "W the spec's sensitivity_weight (s/M + ω_B)/(s + ω_B A); ≤ 1 means |S| ≤ "
                   "1/|W| everywhere",
    "reference": "Skogestad & Postlethwaite, Multivariable Feedback Control (2005), §2.8.2; "
                 "Karimi & Kammer, Automatica 85 (2017), §3"}}
TECHNIQUE = "frequency_response_data(technique=convex)"


class ConvexSolverSpec(SpecModel):
    """Settings of the convex technique (Karimi & Kammer 2017's iterated SOCP)."""

    method: Literal["convex"] = Field(
        "convex", description="convex: iterated second-order cone programs (cvxpy, Clarabel) "
                              "on the measured frequencies")
    max_iter: PositiveInt = Field(50, le=1000, description="Linearisations at most [count]")
    tol: PositiveFloat = Field(1e-4, description="Stop when the objective no longer grows "
                                                 "and the gains move by less [1, relative]")
    time_limit: PositiveFloat = Field(60.0, description="Wall-clock limit [s]")


class SensitivityWeightSpec(SpecModel):
    """The performance weight W(s) = (s/M + ω_B)/(s + ω_B A) of ``weighted_sensitivity``
    (Skogestad & Postlethwaite 2005, §2.8.2): ‖W S‖∞ ≤ 1 asks |S| ≤ A at low frequency,
    |S| ≤ M at high frequency, and a sensitivity bandwidth of about ω_B."""

    bandwidth: PositiveFloat = Field(description="ω_B: the sensitivity's bandwidth asked for "
                                                 "[rad/s]")
    peak: float = Field(gt=1.0, le=100.0, description="M: the bound on |S| at high frequency "
                                                      "(1/|W(j∞)|) [1], > 1")
    low_gain: float = Field(1e-4, gt=0.0, lt=1.0,
                            description="A: the bound on |S| at low frequency (1/|W(0)|) [1], "
                                        "< 1")

    def weight(self):
        from feedtune.measured.datadriven import SensitivityWeight

        return SensitivityWeight(self.bandwidth, self.peak, self.low_gain)


class DataObjective(SpecModel):
    metric: Literal["bandwidth", "crossover_frequency", "weighted_sensitivity"] = Field(
        description="Maximised: the lowest −3 dB point of |T| over the sets (bandwidth), or "
                    "the lowest |L| = 1 point (crossover_frequency) [rad/s]; minimised: the "
                    "largest max |W S| over the sets (weighted_sensitivity) [1]")
    goal: Literal["maximize", "minimize"] = Field(
        "maximize", description="maximize (bandwidth, crossover_frequency) or minimize "
                                "(weighted_sensitivity)")
    weight: PositiveFloat = Field(1.0, description="Weight of the term [s/rad] for a "
                                                   "frequency, [1] for weighted_sensitivity")

    @model_validator(mode="after")
    def _goal_fits(self):
        wanted = "minimize" if self.metric == "weighted_sensitivity" else "maximize"
        if self.goal != wanted:
            raise ValueError(f"{self.metric} can only be {wanted}d here (goal {wanted!r})")
        return self


class DataConstraint(SpecModel):
    metric: Literal["m_peak", "sensitivity_peak", "weighted_sensitivity"] = Field(
        description="m_peak: max |T|; sensitivity_peak: max |S|; weighted_sensitivity: max "
                    "|W S| (sensitivity_weight), at every measured frequency of every set [1]")
    max: PositiveFloat = Field(description="Upper bound [1]; at least 1 for m_peak")
    min: None = Field(None, description="Not available: only upper bounds are convex here")


class DataDrivenSpec(SpecModel):
    """A data-driven tuning problem: measured frequency responses, a controller linear in
    its parameters, a bandwidth to widen and magnitude bounds (``feedtune plants``,
    ``frequency_response_data``)."""

    name: str = Field(min_length=1, max_length=200,
                      description="Name of this tuning problem; printable characters [text]")
    description: str = Field("", max_length=10_000, description="Free text for people")
    plant: FrequencyResponseDataParams
    tunables: dict[str, TunableSpec] = Field(
        default_factory=dict, description="controller.kp/ki/kd: {value} or {min, max, "
                                          "initial} [their units]; initial: a stabilising "
                                          "controller (default: the geometric mid-bound)")
    objective: list[DataObjective] = Field(min_length=1, max_length=1,
                                           description="One term: what to widen")
    constraints: list[DataConstraint] = Field(
        default_factory=list, max_length=3,
        description="m_peak, sensitivity_peak and/or weighted_sensitivity")
    sensitivity_weight: SensitivityWeightSpec | None = Field(
        None, description="W of weighted_sensitivity (needed where that metric is used; "
                          "the metric is reported whenever W is given)")
    solver: ConvexSolverSpec = Field(default_factory=ConvexSolverSpec)

    @field_validator("name")
    @classmethod
    def _printable(cls, name: str) -> str:
        if _CONTROL.search(name):
            raise ValueError("holds a control character (printable characters only)")
        return name

    @field_validator("constraints")
    @classmethod
    def _once_each(cls, constraints: list) -> list:
        names = [c.metric for c in constraints]
        if len(set(names)) < len(names):
            raise ValueError("each metric at most once")
        for c in constraints:
            if c.metric == "m_peak" and c.max < 1.0:
                raise ValueError(f"m_peak max {c.max} < 1: |T| → 1 at low frequency")
        return constraints

    def canonical_json(self) -> str:
        return json.dumps(self.model_dump(mode="json"), sort_keys=True, separators=(",", ":"))

    def sha256(self) -> str:
        return hashlib.sha256(self.canonical_json().encode()).hexdigest()


def parse_data_spec(raw: dict) -> DataDrivenSpec:
    """Validate a data-driven spec (parsed JSON); every problem by JSON pointer.

    Raises
    ------
    feedtune.schema.spec.SpecError
    """
    from feedtune.schema.spec import SpecError, _schema_errors, tunable_box

    try:
        spec = DataDrivenSpec.model_validate(raw, strict=True)
    except ValidationError as exc:
        raise SpecError(_schema_errors(exc, raw)) from None
    tunables = FrequencyResponseData(spec.plant).tunables()
    errors = [(f"/tunables/{name}", f"unknown tunable for controller {spec.plant.controller!r}; "
                                    f"known: {', '.join(tunables)}")
              for name in spec.tunables if name not in tunables]
    _, box_errors, _ = tunable_box(spec.tunables, tunables)
    errors += box_errors
    used = [t.metric for t in [*spec.objective, *spec.constraints]]
    if "weighted_sensitivity" in used and spec.sensitivity_weight is None:
        errors.append(("/sensitivity_weight", "weighted_sensitivity needs the weight W: "
                                              "{bandwidth [rad/s], peak [1], low_gain [1]}"))
    if errors:
        raise SpecError(errors)
    return spec


def frd_plant_block(data: Sequence, names: Sequence[str] | None = None, *,
                    controller: str = "pi", filter_time_constant: float | None = None,
                    integrators: int = 1, unstable_poles: int = 0) -> dict:
    """The ``plant`` block of a data-driven spec from measured frequency responses: what
    ``feedtune identify DATA... --model frd`` writes.

    Parameters
    ----------
    data : sequence of feedtune.measured.data.FrequencyResponseData
        One per set, all with the same units: position responses (``m`` or ``rad`` per
        command unit), or velocity responses (``m/s``, ``rad/s``), integrated here (÷ jω).
    names : sequence of str, optional
        A name per set; default: each file's stem.
    controller, filter_time_constant, integrators, unstable_poles
        As the plant's fields (``feedtune plants``); τ_f [s].

    Returns
    -------
    dict
        ``{"type": "frequency_response_data", "sets": [...], ...}`` with frequencies in
        rad/s, checked by the plant's own model.

    Raises
    ------
    ValueError
        Units that differ between sets, or a block the plant refuses.
    """
    from pathlib import Path

    if not data:
        raise ValueError("no frequency response given")
    units = {(d.input_unit, d.output_unit) for d in data}
    if len(units) > 1:
        raise ValueError(f"the sets' units differ: {sorted(units)}")
    (input_unit, output_unit), = units
    names = list(names) if names is not None else [Path(d.source).stem for d in data]
    position = output_unit.removesuffix("/s")
    sets = []
    for name, d in zip(names, data):
        response = d.response
        if position != output_unit:  # a velocity response: position = velocity/(jω)
            response = response / (1j * d.frequency_rad_s)
        sets.append({"name": name, "frequency_unit": "rad/s",
                     "frequency": [float(w) for w in d.frequency_rad_s],
                     "real": [float(v) for v in response.real],
                     "imag": [float(v) for v in response.imag]})
    block = {"type": "frequency_response_data", "input_unit": input_unit,
             "output_unit": position, "integrators": integrators,
             "unstable_poles": unstable_poles, "controller": controller, "sets": sets}
    if filter_time_constant is not None:
        block["filter_time_constant"] = filter_time_constant
    FrequencyResponseDataParams.model_validate(block)
    return block


def tune_data_driven(spec: DataDrivenSpec):
    """Solve a data-driven spec; a failed design is a result with ``success`` false.

    Returns
    -------
    feedtune.schema.result.TuneResult
    """
    import time

    from feedtune.measured.datadriven import DataDrivenError, design
    from feedtune.schema.result import (ConstraintResult, MetricValue, SolverResult, TunedValue,
                                        TuneResult, provenance)
    from feedtune.schema.spec import tunable_box
    from feedtune.validate import validate_result

    plant = FrequencyResponseData(spec.plant)
    tunables = plant.tunables()
    box, _, _ = tunable_box(spec.tunables, tunables)
    initial = {}
    for name, (lo, hi) in box.items():
        given = spec.tunables.get(name)
        initial[name] = (given.initial if given is not None and given.initial is not None
                         else math.sqrt(lo * hi))
    short = {name.removeprefix("controller."): value for name, value in box.items()}
    bounds = {c.metric: c.max for c in spec.constraints}
    objective = spec.objective[0]
    weight = spec.sensitivity_weight.weight() if spec.sensitivity_weight is not None else None
    started = time.perf_counter()

    def failed(message: str) -> TuneResult:
        return TuneResult(
            name=spec.name, success=False, status=ERROR, message=message, objective=None,
            tuned={}, metrics={}, constraints=[], stability={"stable": False},
            solver=SolverResult(method="convex", return_status="not_run", message=message,
                                iterations=0, solve_time=0.0, build_time=0.0,
                                evaluation_time=0.0, model_gap=None, starts=[]),
            provenance=provenance(spec.sha256()), spec=spec.model_dump(mode="json"))

    try:
        found = design(plant.sets(), plant.basis(), short,
                       {name.removeprefix("controller."): v for name, v in initial.items()},
                       m_peak=bounds.get("m_peak"),
                       sensitivity_peak=bounds.get("sensitivity_peak"),
                       weighted_sensitivity=bounds.get("weighted_sensitivity"), weight=weight,
                       objective=objective.metric, integrators=spec.plant.integrators,
                       unstable_poles=spec.plant.unstable_poles, max_iter=spec.solver.max_iter,
                       tol=spec.solver.tol, time_limit=spec.solver.time_limit)
    except DataDrivenError as exc:
        return failed(exc.message)
    except Exception as exc:  # noqa: BLE001 — a failure is a result, never a traceback
        return failed(f"{type(exc).__name__}: {exc}")
    elapsed = time.perf_counter() - started

    tuned = {}
    for name, tunable in tunables.items():
        lo, hi = box[name]
        value = found.values[name.removeprefix("controller.")]
        at_bound = None if lo == hi else ("min" if value <= lo * (1 + 1e-6) else
                                          "max" if value >= hi * (1 - 1e-6) else None)
        tuned[name] = TunedValue(value=value, unit=tunable.unit, fixed=lo == hi, min=lo, max=hi,
                                 at_bound=at_bound)
    stable = found.stable
    metrics = {key: MetricValue(metric=key, value=found.metrics[key] if stable else None,
                                unit=unit) for key, unit in UNITS.items() if key in found.metrics}
    for data, per_set in zip(spec.plant.sets, found.per_set):
        for key, value in per_set.items():
            if key not in UNITS:
                continue  # the peaks at the measured points only: the design's inner bounds
            options = {"set": data.name}
            metrics[metric_label(key, options)] = MetricValue(
                metric=key, value=value if stable else None, unit=UNITS[key], options=options)
    constraints = []
    for c in spec.constraints:
        value = found.metrics[c.metric]
        constraints.append(ConstraintResult(metric=c.metric, max=c.max, min=None,
                                            value=value if stable else None,
                                            satisfied=stable and value <= c.max * (1 + 1e-6)))
    value = found.metrics[objective.metric]
    lows = [c.band[0] for c in found.certificates]
    highs = [c.band[1] for c in found.certificates]
    stability = {"stable": stable, "certified_by": "nyquist",
                 "band": [min(lows), max(highs)],
                 "how": ("Nyquist count of 1 + L on each measured set, with the declared "
                         f"{spec.plant.integrators} plant integrator(s) and "
                         f"{spec.plant.unstable_poles} unstable pole(s); assumes the plant "
                         "follows its integrators below the band and |L| < 1 above it"),
                 "sets": [c.as_dict() for c in found.certificates]}
    success = (found.status == OPTIMAL and stable and value is not None
               and all(c.satisfied for c in constraints))
    message = found.message
    if value is None:
        message += (f"; the {objective.metric} lies above the measured band on some set: "
                    "measure higher frequencies")
    sign = -1.0 if objective.goal == "maximize" else 1.0
    solver = SolverResult(method="convex", return_status=found.status, message=found.message,
                          iterations=found.iterations, solve_time=found.solve_time,
                          build_time=found.build_time,
                          evaluation_time=max(elapsed - found.solve_time - found.build_time, 0.0),
                          model_gap=None, starts=[])
    result = TuneResult(
        name=spec.name, success=success, status=found.status, message=message,
        objective=sign * objective.weight * value if (stable and value is not None) else None,
        tuned=tuned, metrics=metrics, constraints=constraints, stability=stability,
        solver=solver, provenance=provenance(spec.sha256()), spec=spec.model_dump(mode="json"))
    # re-evaluated on every measured frequency with the validator's own arithmetic
    return result.model_copy(update={"validation": validate_result(result)})
