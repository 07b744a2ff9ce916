"""The result of a tuning: one type whatever happened, with provenance."""

from __future__ import annotations

import functools
import os
import platform
import tempfile
from typing import Any, Literal

import casadi as ca
from pydantic import Field

from feedtune.schema.model import ExtendedFloat, SpecModel
from feedtune.schema.status import Status
from feedtune.schema.uncertainty import UncertainParameter


ResultModel = SpecModel  # results are as strict as specs: frozen, no unknown keys, no NaN


class TunedValue(ResultModel):
    value: float = Field(description="Tuned value [unit]")
    unit: str
    fixed: bool = Field(description="True when the spec fixed this tunable")
    min: float | None = Field(None, description="Lower bound searched [unit]")
    max: float | None = Field(None, description="Upper bound searched [unit]")
    at_bound: Literal["min", "max"] | None = Field(None, description="Bound the optimum lies on, if any")


#: how a value's description says that it may be infinite
INFINITE = ('; the string "Infinity" where the value is +∞ because its quantity does not '
            'exist (a gain margin without a phase crossover), "-Infinity" for −∞')


class MetricValue(ResultModel):
    metric: str
    value: ExtendedFloat | None = Field(
        description="Value at the tuned point [unit]; null where undefined, and for every "
                    "metric when the tuned loop is unstable" + INFINITE)
    unit: str
    options: dict[str, Any] = Field(default_factory=dict)


class ConstraintResult(ResultModel):
    metric: str
    options: dict[str, Any] = Field(default_factory=dict)
    min: float | None
    max: float | None
    value: ExtendedFloat | None = Field(
        description="The constraint's value at the tuned point [the metric's unit]; null "
                    "where undefined or the loop is unstable" + INFINITE)
    satisfied: bool = Field(description="Stable, and min ≤ value ≤ max (+∞ meets a min "
                                        "and no max)")


class StartResult(ResultModel):
    index: int
    status: Status
    return_status: str
    objective: float | None
    iterations: int = Field(description="IPOPT iterations, summed over exchange rounds; "
                                        "brent: Brent's iterations; root: evaluations of the "
                                        "error beyond the shared grid [count]")
    exchange_points: int = Field(
        0, description="Frequencies added to peak/crossing constraints after IPOPT found the "
                       "refined peak (or dip) beyond its bound [count]")
    solve_time: float = Field(description="[s]")
    feasible: bool
    method: Literal["ipopt", "brent", "root", "differential_evolution"] = Field(
        "ipopt", description="What solved this start: see the solver's method")


class SolverResult(ResultModel):
    method: Literal["ipopt", "brent", "root", "differential_evolution", "convex"] = Field(
        "ipopt", description="The chosen start's: ipopt: the NLP with exact derivatives; "
                             "brent: the scalar search of one tunable; root: a root of the "
                             "signed error (one tunable, one |e| minimised), or the "
                             "constraint's crossing where |e| is least; differential_evolution: "
                             "the search on an exact simulation (pulse generators); convex: "
                             "iterated SOCPs on measured frequency responses")
    return_status: str = Field(description="The solver's own return status of the chosen start "
                                           "(IPOPT's names, also for the search)")
    message: str
    iterations: int = Field(description="The chosen start's iterations (IPOPT's; for root, "
                                        "its evaluations of the error) [count]")
    solve_time: float = Field(description="Wall time of all starts [s]")
    build_time: float = Field(description="Wall time to build the NLP [s]")
    evaluation_time: float = Field(description="Wall time to evaluate every metric at the tuned point [s]")
    model_gap: float | None = Field(
        description="Largest relative gap between the objective/constraints as the NLP saw them "
                    "and their exact evaluation at the tuned point [1]")
    starts: list[StartResult]


class SpreadValue(ResultModel):
    min: float = Field(description="Smallest value among the equal optima [unit]")
    max: float = Field(description="Largest value among the equal optima [unit]")
    unit: str


class OptimumCheck(ResultModel):
    """Whether the tuned point is the only one with the best objective, judged from the
    starts: several starts reaching the best objective at different tunables show a flat
    direction (e.g. zero radial error along a curve K(T)) or several optima."""

    unique: bool | None = Field(
        description="false: a flat direction at the optimum, or other starts reaching the "
                    "same objective at different tunables; true: neither; null: not examined "
                    "(no NLP was solved and fewer than two starts reached the optimum)")
    starts: list[int] = Field(
        default_factory=list, description="Starts (1-based) that reached the best objective")
    spread: dict[str, SpreadValue] = Field(
        default_factory=dict, description="Tunables that differ between those starts")
    flat: list[str] = Field(
        default_factory=list,
        description="Tunables along a direction in which the objective does not change to "
                    "second order while every active constraint holds (reduced Hessian of "
                    "the Lagrangian at the optimum)")
    advice: str | None = Field(None, description="How to make the optimum unique")


class ScenarioResult(ResultModel):
    """One scenario of a robust tuning: the uncertain numbers, and the tuned design's
    constraints and stability there (the tuner's exact evaluation)."""

    parameters: dict[str, float] = Field(description="The uncertain numbers [each its unit]")
    origin: Literal["nominal", "corner", "interior", "worst_case"] = Field(
        description="nominal: the plant as given; corner: a combination of the sets' values "
                    "and the ranges' ends; interior: a Latin-hypercube sample of the ranges; "
                    "worst_case: added by the worst-case search")
    round: int = Field(description="The solve that first held it [count, from 1]")
    stable: bool
    constraints: list[ExtendedFloat | None] = Field(
        description="Each constraint's value, in the spec's order [its unit]; null where the "
                    "loop is unstable" + INFINITE)
    satisfied: bool = Field(description="Stable, and every constraint within its bound")


class WorstCase(ResultModel):
    """One constraint's worst value over the whole uncertainty (a dense sample refined
    locally), after the last solve."""

    metric: str
    options: dict[str, Any] = Field(default_factory=dict)
    min: float | None
    max: float | None
    parameters: dict[str, float] = Field(description="Where it is worst [each its unit]")
    value: ExtendedFloat | None = Field(description="Its value there [the metric's unit]"
                                                    + INFINITE)
    margin: ExtendedFloat | None = Field(
        description="How far inside its bounds it is there, negative outside [the metric's "
                    "unit]; null for an unstable loop" + INFINITE)
    tolerance: float = Field(description="The violation allowed: the robust tolerance times "
                                         "the bound's size [the metric's unit]")
    satisfied: bool


class RobustResult(ResultModel):
    """Robust tuning over uncertain plant numbers (feedtune.robust)."""

    objective: Literal["nominal", "worst_case"]
    parameters: dict[str, UncertainParameter] = Field(
        description="The uncertain numbers as the spec gives them [each its unit]")
    scenarios: list[ScenarioResult] = Field(description="Every scenario the last solve held")
    worst_cases: list[WorstCase] = Field(description="Each constraint's worst case, in the "
                                                     "spec's order")
    rounds: int = Field(description="Solves of the NLP [count]")
    converged: bool = Field(description="No constraint violated anywhere in the uncertainty "
                                        "beyond its tolerance")
    tolerance: float = Field(description="The violation allowed, as a fraction of each "
                                         "constraint's bound [1]")
    unstable_parameters: dict[str, float] | None = Field(
        None, description="The most unstable numbers found by the last search; null: the "
                          "loop is stable at every point searched [each its unit]")
    search: str | None = Field(
        None, description="How the last search looked for each constraint's worst case: the "
                          "dense sample, the local refinement and the exact evaluations "
                          "[text]; null: no solve to search around")


class Provenance(ResultModel):
    feedtune: str
    casadi: str
    ipopt: str
    python: str
    spec_sha256: str = Field(description="SHA-256 of the canonical spec (sorted keys, defaults filled)")


class TuneResult(ResultModel):
    """Everything a tuning produced; ``success`` is true only for a feasible, stable optimum."""

    name: str
    success: bool
    status: Status
    message: str
    objective: float | None = Field(description="Weighted objective at the tuned point [its terms' units]")
    tuned: dict[str, TunedValue]
    metrics: dict[str, MetricValue]
    constraints: list[ConstraintResult]
    stability: dict[str, Any]
    solver: SolverResult
    provenance: Provenance
    spec: dict[str, Any] = Field(description="The canonical spec that was solved")
    optimum: OptimumCheck | None = Field(
        None, description="Whether the optimum is unique (see OptimumCheck); null when no "
                          "start succeeded, and in older results")
    warnings: list[str] = Field(
        default_factory=list, description="Ways the tuned design is implausible on its own "
                                          "terms (counter overflow, a unit slip, contradictory "
                                          "plant data); each is also printed on stderr")
    robust: RobustResult | None = Field(
        None, description="Robust tuning over the spec's uncertain plant numbers: scenarios, "
                          "worst case per constraint; null when the plant is known exactly")
    validation: dict[str, Any] | None = Field(
        None, description="Independent numpy/scipy re-simulation of the tuned design "
                          "(feedtune.validate): each metric as reported and as re-measured, "
                          "the gap |reported − validated| and its tolerance max(rel·|value|, "
                          "fraction·physical scale), both in the metric's unit, and the "
                          "scale that set it (docs/validation.md); null in older results")


@functools.cache
def ipopt_version() -> str:
    """IPOPT's version, read from its own log of a one-variable solve (stdout untouched)."""
    path = os.path.join(tempfile.mkdtemp(prefix="feedtune-"), "ipopt.log")
    x = ca.MX.sym("x")
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as devnull:
            os.dup2(devnull.fileno(), 1)
            solver = ca.nlpsol("version_probe", "ipopt", {"x": x, "f": x**2},
                               {"ipopt": {"print_level": 0, "sb": "yes", "output_file": path,
                                          "file_print_level": 5, "option_file_name": ""},
                                "print_time": False})  # "": never read ./ipopt.opt
            solver(x0=1)
    finally:
        os.dup2(saved, 1)
        os.close(saved)
    try:
        with open(path) as log:
            for line in log:
                if "Ipopt version" in line:
                    return line.split("version")[1].split(",")[0].strip()
    finally:
        os.remove(path)
        os.rmdir(os.path.dirname(path))
    return "unknown"


def provenance(spec_sha256: str) -> Provenance:
    from feedtune import __version__

    return Provenance(feedtune=__version__, casadi=ca.__version__, ipopt=ipopt_version(),
                      python=platform.python_version(), spec_sha256=spec_sha256)
