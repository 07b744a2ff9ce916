"""What the tuner is given and what it gives back: shared by the NLP and the search tuner.

Given: :class:`Variable` (a free tunable), :class:`Term` (objective term), :class:`Bound`
(constraint), :class:`Settings` (solver settings). Given back: :class:`Outcome`, with a
:class:`StartOutcome` per start. :data:`STATUS` maps IPOPT's (and feedtune's own) return
statuses to the result's status vocabulary.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Mapping

from feedtune.schema.status import ACCEPTABLE, INFEASIBLE, ITERATION_LIMIT, OPTIMAL, TIME_LIMIT
from feedtune.schema.status import SOLVED  # noqa: F401  (the tuner's modules read it here)

#: relative tolerance when reporting whether a bound holds
FEASIBILITY_TOL = 1e-6
#: options that name a file or library, or choose one to load: refused whatever the caller
LIBRARY_IPOPT_OPTIONS = frozenset({"hsllib", "pardisolib", "linear_solver",
                                   "linear_system_scaling", "nlp_scaling_method"})
SAFE_LIBRARY_CHOICES = frozenset({"mumps", "none", "slack-based", "gradient-based"})

#: IPOPT's return status (and feedtune's own, see feedtune.tuner.nlp) → the result's status
STATUS = {
    "Solve_Succeeded": OPTIMAL,
    "Solved_To_Acceptable_Level": ACCEPTABLE,
    "Infeasible_Problem_Detected": INFEASIBLE,
    "Maximum_Iterations_Exceeded": ITERATION_LIMIT,
    "Maximum_CpuTime_Exceeded": TIME_LIMIT,
    "Maximum_WallTime_Exceeded": TIME_LIMIT,
    "Exchange_Points_Exhausted": ITERATION_LIMIT,  # feedtune's: no exchange point left
    "No_Stable_Start": INFEASIBLE,  # feedtune's: restoration found no stable point
}


@dataclass(frozen=True)
class Variable:
    """A free tunable, optimised as ln(value) within [lower, upper] (both > 0, its unit)."""

    name: str
    lower: float
    upper: float
    initial: float | None = None


@dataclass(frozen=True)
class Term:
    """Objective term ``weight · value(loop)``; ``value`` may return a Magnitude.

    ``group``: the objective is the largest over groups of each group's weighted sum
    (:mod:`feedtune.tuner.scenarios`); with one group, the sum of every term.
    """

    label: str
    value: Callable
    weight: float = 1.0
    group: int = 0


@dataclass(frozen=True)
class Bound:
    """Constraint ``lower ≤ value(loop) ≤ upper`` (None: unbounded on that side)."""

    label: str
    value: Callable
    lower: float | None
    upper: float | None


@dataclass(frozen=True)
class Settings:
    """Solver settings: starts [count], IPOPT's iteration limit per round [count] and
    tolerance [1], the wall-clock limit of a start [s], SX expansion (None: automatic),
    further IPOPT options, and whether a problem of one free tunable may be solved by the
    scalar search (:mod:`feedtune.tuner.scalar`), or with one |e| minimised by the root
    search (:mod:`feedtune.tuner.roots`), instead of IPOPT: only when no IPOPT option is
    given."""

    multistart: int = 8
    max_iter: int = 500
    tol: float = 1e-9
    time_limit: float = 60.0
    expand: bool | None = None
    ipopt_options: Mapping[str, object] = field(default_factory=dict)
    scalar_search: bool = True

    def __post_init__(self):
        """Refuse IPOPT options that would load a library, whoever built the settings (a
        spec's options are allow-listed by :mod:`feedtune.schema.spec` before they get here)."""
        for name, value in self.ipopt_options.items():
            if name in LIBRARY_IPOPT_OPTIONS and value not in SAFE_LIBRARY_CHOICES:
                raise ValueError(f"IPOPT option {name} = {value!r} would load a library")


@dataclass
class StartOutcome:
    """What one start did: status, objective, iterations (IPOPT's, or the search's
    evaluations: see ``method``), wall time [s], feasibility, the exchange points it added
    and the method that solved it (``ipopt``, ``brent``, ``root``, ...)."""

    index: int
    status: str
    return_status: str
    objective: float | None
    iterations: int
    solve_time: float
    feasible: bool
    exchange_points: int = 0
    method: str = "ipopt"


@dataclass
class Outcome:
    """What the tuner found: the best start, and what every start did."""

    status: str
    return_status: str
    message: str
    success: bool
    values: dict[str, float]
    objective: float | None
    reports: dict[str, float | None]
    constraints: list[tuple[Bound, float | None, bool]]
    stability: dict
    iterations: int
    solve_time: float
    build_time: float
    evaluation_time: float
    model_gap: float
    horizon_bound: bool  # the optimum lies on the loop's settling conditions: lengthen it
    starts: list[StartOutcome]
    method: str = "ipopt"  # the solver that produced it
    #: every start that reached the best objective, the best first: (index, free tunables)
    equal_optima: list[tuple[int, dict[str, float]]] = field(default_factory=list)
    #: tunables along a flat direction at the optimum (None: not examined)
    flat_tunables: list[str] | None = None


def finite(x) -> float | None:
    """``x`` as a float, or None when it is not finite."""
    value = float(x)
    return value if math.isfinite(value) else None


def number(x) -> float | None:
    """``x`` as a float, ±∞ included (an :class:`~feedtune.expr.Unbounded` value where its
    quantity does not exist), or None when it is NaN."""
    value = float(x)
    return None if math.isnan(value) else value


def within(value: float | None, lower: float | None, upper: float | None) -> bool:
    """``lower ≤ value ≤ upper`` within FEASIBILITY_TOL relative to max(1, |bound|); a
    missing value holds no bound; +∞ holds a lower bound only."""
    if value is None:
        return False
    if lower is not None and value < lower - FEASIBILITY_TOL * max(1.0, abs(lower)):
        return False
    if upper is not None and value > upper + FEASIBILITY_TOL * max(1.0, abs(upper)):
        return False
    return True
