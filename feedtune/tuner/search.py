"""Derivative-free search on an exact simulation, for loops the NLP cannot take.

A loop that declares ``exact_only`` (Tian's pulse generator, :mod:`feedtune.loops.pulse_train`)
is a discrete simulation: its metrics are piecewise constant in the tunables (a pulse more
or less), so they have no useful derivatives and IPOPT cannot be used. This tuner runs
scipy's differential evolution on the same ``make_loop`` / metric callables the NLP tuner
gets, over the logarithms of the free tunables (as the NLP does), with a deterministic
seed per start (``multistart`` starts: seeds 0, 1, …; the first start's population holds
the initial point). Constraints and the loop's ``stability()`` (a step that comes to
rest, a ramp or sine still tracked) are handled by a penalty that ranks every infeasible
candidate behind every feasible one: PENALTY plus the summed relative violations. No
polishing: a gradient step on a staircase goes nowhere.

Every number in the Outcome is from the exact simulation at the returned point: the
search and the evaluation are the same code, so the model gap is 0.

The tuner sees only the loop interface and metric callables; it imports neither plants
nor objectives.
"""

from __future__ import annotations

import math
import time
from typing import Callable, Mapping

import numpy as np
from scipy import optimize

from feedtune.schema.status import ACCEPTABLE, INFEASIBLE, ITERATION_LIMIT, OPTIMAL, TIME_LIMIT
from feedtune.tuner.nlp import Problem
from feedtune.tuner.scenarios import objective_value
from feedtune.tuner.types import (Bound, Outcome, Settings, StartOutcome, Term, Variable,
                                  within as _within)

#: an infeasible candidate scores PENALTY + its violation: worse than any feasible objective
PENALTY = 1e9
#: population per free tunable (scipy's popsize)
POPULATION = 8
#: the initial population: scipy's own Latin hypercube, its default ("sobol" imports
#: ``scipy.stats``, 0.25–0.5 s of a process; benchmarks/tian_population.py compares them)
INITIAL_POPULATION = "latinhypercube"
#: generations per start at most (also bounded by Settings.max_iter and time_limit)
GENERATIONS = 40


def is_exact_only(loop) -> bool:
    """The loop is an exact (discrete) simulation that only this tuner can tune."""
    return bool(loop.exact_only)


def problem_class(loop) -> type:
    """The tuner for ``loop``: :class:`SearchProblem` for exact-only loops, else the NLP's
    :class:`~feedtune.tuner.nlp.Problem` (both take the same arguments and return an
    :class:`~feedtune.tuner.nlp.Outcome`)."""
    return SearchProblem if is_exact_only(loop) else Problem


def _value(x) -> float | None:
    try:
        value = float(x)
    except (TypeError, ValueError):
        return None
    return value if math.isfinite(value) else None


class SearchProblem:
    """Same constructor and :meth:`solve` as :class:`~feedtune.tuner.nlp.Problem`."""

    def __init__(self, variables: list[Variable], fixed: Mapping[str, float],
                 make_loop: Callable, objective: list[Term], constraints: list[Bound],
                 reports: Mapping[str, Callable], settings: Settings,
                 numbers: Mapping[str, float] | None = None, structure_key: str | None = None):
        self.variables = list(variables)
        self.fixed = dict(fixed)
        self.make_loop = make_loop
        self.objective = list(objective)
        self.bounds = list(constraints)
        self.reports = dict(reports)
        self.settings = settings
        self.evaluations = 0
        self._cache: dict[tuple, tuple] = {}

    def _values(self, z: np.ndarray) -> dict[str, float]:
        values = {v.name: float(math.exp(z[i])) for i, v in enumerate(self.variables)}
        values.update(self.fixed)
        return values

    def measure(self, values: Mapping[str, float]):
        """(loop, objective or None, constraint values, stable) at ``values``, simulated now."""
        loop = self.make_loop(dict(values))
        objective = objective_value([term.weight for term in self.objective],
                                    [_value(term.value(loop)) for term in self.objective],
                                    [term.group for term in self.objective])
        bounds = [_value(b.value(loop)) for b in self.bounds]
        stable = bool(loop.stability()["stable"])
        return loop, objective, bounds, stable

    def evaluate(self, values: Mapping[str, float]):
        """(objective or None, constraint values, stable) at ``values``, each point simulated
        once. The cache keeps these numbers only, not the loop: a loop holds its whole
        simulated response, and a search visits thousands of points."""
        key = tuple(sorted(values.items()))
        numbers = self._cache.get(key)
        if numbers is None:
            self.evaluations += 1
            numbers = self.measure(values)[1:]
            if len(self._cache) > 10000:
                self._cache.clear()
            self._cache[key] = numbers
        return numbers

    def _violation(self, bounds, stable) -> float:
        total = 0.0 if stable else 1.0
        for value, b in zip(bounds, self.bounds):
            if value is None:
                total += 1.0
                continue
            if b.lower is not None and value < b.lower:
                total += (b.lower - value) / max(1.0, abs(b.lower))
            if b.upper is not None and value > b.upper:
                total += (value - b.upper) / max(1.0, abs(b.upper))
        return total

    def _score(self, z: np.ndarray) -> float:
        objective, bounds, stable = self.evaluate(self._values(z))
        feasible = stable and all(_within(v, b.lower, b.upper) for v, b in zip(bounds, self.bounds))
        if feasible and objective is not None:
            return objective
        return PENALTY * (1.0 + self._violation(bounds, stable))

    def _start(self, seed: int, deadline: float):
        lower = np.log([v.lower for v in self.variables])
        upper = np.log([v.upper for v in self.variables])
        x0 = None
        if seed == 0:
            x0 = np.array([math.log(v.initial) if v.initial else (lo + hi) / 2
                           for v, lo, hi in zip(self.variables, lower, upper)])
        stopped = {"time": False}

        def callback(*_args, **_kwargs):
            if time.perf_counter() > deadline:
                stopped["time"] = True
                return True
            return False

        result = optimize.differential_evolution(
            self._score, list(zip(lower, upper)), seed=seed, popsize=POPULATION,
            maxiter=min(GENERATIONS, self.settings.max_iter), tol=1e-6, atol=0.0, polish=False,
            init=INITIAL_POPULATION, x0=x0,
            callback=callback, updating="immediate")
        if stopped["time"]:
            return result.x, "Maximum_WallTime_Exceeded", TIME_LIMIT, int(result.nit)
        if result.success:
            return result.x, "Search_Converged", OPTIMAL, int(result.nit)
        return result.x, "Maximum_Iterations_Exceeded", ITERATION_LIMIT, int(result.nit)

    def solve(self, progress: Callable[[StartOutcome, int], None] | None = None) -> Outcome:
        """Run ``multistart`` seeded searches; the best feasible one is the result."""
        begun = time.perf_counter()
        deadline = begun + self.settings.time_limit
        starts: list[StartOutcome] = []
        best = None  # (key, index, z, return_status, status)
        count = max(1, self.settings.multistart) if self.variables else 1
        for index in range(count):
            started = time.perf_counter()
            if self.variables:
                z, return_status, status, iterations = self._start(index, deadline)
            else:
                z, return_status, status, iterations = np.zeros(0), "No_Free_Tunables", OPTIMAL, 0
            objective, bounds, stable = self.evaluate(self._values(z))
            feasible = stable and all(_within(v, b.lower, b.upper) for v, b in zip(bounds, self.bounds))
            starts.append(StartOutcome(index, status, return_status, objective, iterations,
                                       time.perf_counter() - started, feasible,
                                       method="differential_evolution"))
            if progress is not None:
                progress(starts[-1], count)
            solved = status == OPTIMAL and feasible and objective is not None
            usable = feasible and objective is not None
            key = ((0, objective, index) if solved else (1, objective, index) if usable
                   else (2, self._violation(bounds, stable), index))
            if best is None or key < best[0]:
                best = (key, index, z, return_status, status)
            if status == TIME_LIMIT:
                break
        key, index, z, return_status, status = best
        started = time.perf_counter()
        values = self._values(z)
        loop, objective, bounds, stable = self.measure(values)  # the same numbers, simulated again
        reports = {name: _value(fn(loop)) for name, fn in self.reports.items()}
        stability = loop.stability()
        feasible = key[0] < 2
        success = feasible
        if feasible and status != OPTIMAL:
            status = ACCEPTABLE  # feasible, but the search stopped before converging
        if success:
            message = (f"start {index + 1} of {len(starts)} gave the best feasible point "
                       f"(differential evolution on the exact simulation, "
                       f"{self.evaluations} simulations)")
        else:
            status = INFEASIBLE
            broken = [b.label for v, b in zip(bounds, self.bounds) if not _within(v, b.lower, b.upper)]
            if not stable:
                broken.append("settling (the response did not come to rest or lost track)")
            message = "no start satisfied every constraint; violated: " + ", ".join(broken)
        return Outcome(
            status=status, return_status=return_status, message=message, success=success,
            values=values, objective=objective, reports=reports,
            constraints=[(b, v, _within(v, b.lower, b.upper)) for b, v in zip(self.bounds, bounds)],
            stability=stability, iterations=starts[index].iterations,
            solve_time=sum(s.solve_time for s in starts), build_time=0.0,
            evaluation_time=time.perf_counter() - started, model_gap=0.0,
            horizon_bound=False, starts=starts, method="differential_evolution")
