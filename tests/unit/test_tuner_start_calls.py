"""What one multistart start evaluates besides IPOPT (issue 15's batch: ≈ 3 starts a spec).

Every start is evaluated once when the problem is built (the objective's and conditions'
scales at the starts, :meth:`Problem._seen_at`); restoration's first check reads the
conditions and matrices seen there instead of calling the stability Function again, and a
problem without peaks or crossings over frequency asks for no exchange levels.
"""

import math

import casadi as ca
import numpy as np
import pytest

from feedtune.tuner.nlp import Problem
from feedtune.tuner.types import Settings, Term, Variable

#: the toy loop is stable for k < LIMIT
LIMIT = 5.0


class Loop:
    """A loop whose poles k − LIMIT ± j [1/s] are stable for k < LIMIT (complex, so that
    restoration's Re λ/|λ| falls as k does)."""

    discrete = False
    unrolled_steps = 0

    def __init__(self, values):
        self.values = values

    def stability_conditions(self):
        return [LIMIT - self.values["k"]]

    def settling_conditions(self):
        return []

    def embedded_reads(self):
        return frozenset()  # no embedded numbers (Loop protocol)

    def stability_matrices(self):
        real = self.values["k"] - LIMIT
        return {"closed_loop": ca.vertcat(ca.horzcat(real, -1), ca.horzcat(1, real))}


def _counted(problem: Problem, name: str) -> list:
    """Wrap ``problem``'s Function attribute ``name``; the list collects its calls' inputs."""
    calls = []
    function = getattr(problem, name)

    def wrapper(*args):
        calls.append(args)
        return function(*args)

    setattr(problem, name, wrapper)
    return calls


#: IPOPT named, so a one-tunable problem is solved by IPOPT's starts, not the scalar search
SETTINGS = {"ipopt_options": {"hessian_approximation": "exact"}}


def _problem(upper: float, initial: float, starts: int) -> Problem:
    """min (k − 2)² over k in [0.5, ``upper``] from ``initial`` and ``starts`` − 1 more."""
    problem = Problem([Variable("k", 0.5, upper, initial=initial)], {}, Loop,
                      [Term("f", lambda loop: (loop.values["k"] - 2) ** 2)], [], {},
                      Settings(multistart=starts, **SETTINGS))
    assert problem.scalar is None
    return problem


def test_stable_starts_are_judged_on_what_was_seen_at_them():
    problem = _problem(4.9, 1.0, 3)  # every start stable
    calls = _counted(problem, "stability_check")
    outcome = problem.solve()
    assert outcome.success and math.isclose(outcome.values["k"], 2.0, rel_tol=1e-6)
    assert calls == []  # three stable starts, each seen when the problem was built
    # the conditions and matrices seen are the stability Function's, to the bit
    for z0 in problem.starts:
        seen = problem._seen_at(z0)
        conditions, matrix = problem.stability_check(z0, problem.param_values)
        np.testing.assert_array_equal(seen.stability, np.asarray(conditions).ravel())
        np.testing.assert_array_equal(seen.matrices["closed_loop"], np.asarray(matrix))


def test_an_unstable_start_is_still_restored():
    problem = _problem(9.0, 8.0, 1)  # k = 8 is unstable
    calls = _counted(problem, "stability_check")
    outcome = problem.solve()
    assert outcome.success and math.isclose(outcome.values["k"], 2.0, rel_tol=1e-6)
    # restoration looked at points it had not seen (k = 8 itself was seen: unstable)
    assert calls and all(math.exp(float(z[0])) != 8.0 for z, _ in calls)


def test_no_exchange_levels_without_peaks_or_crossings():
    problem = _problem(4.9, 1.0, 2)
    assert problem.exchange_groups == []
    calls = _counted(problem, "_exchange_levels")
    assert problem.solve().success
    assert calls == []


def _free_problem(starts: int) -> Problem:
    """min (k − 2)² over k in [1, 4.9], no initial: the first start is the box's geometric
    middle, (ln 1 + ln 4.9)/2, and so is the second, ln 1 + (ln 4.9 − ln 1)/2, to the bit
    (Halton's point 1/2 of the box in one dimension; a lower bound of 1 makes both ln 4.9/2,
    as every batch spec's position gain)."""
    problem = Problem([Variable("k", 1.0, 4.9)], {}, Loop,
                      [Term("f", lambda loop: (loop.values["k"] - 2) ** 2)], [], {},
                      Settings(multistart=starts, **SETTINGS))
    assert problem.scalar is None
    return problem


def test_a_start_from_an_earlier_starts_point_is_that_run():
    """One free tunable without an initial point: starts 1 and 2 are the same point, so
    the second is the first's run (the same inputs to the same solver give the same
    iterates, as a fresh problem's solve of start 2 alone shows), and IPOPT runs twice for
    three starts."""
    problem = _free_problem(3)
    np.testing.assert_array_equal(problem.starts[0], problem.starts[1])
    assert not np.array_equal(problem.starts[0], problem.starts[2])
    calls = []
    solve_from = problem._solve_from

    def counted(start, *args):
        calls.append(np.array(start))
        return solve_from(start, *args)

    problem._solve_from = counted
    outcome = problem.solve()
    assert len(calls) == 2
    np.testing.assert_array_equal(calls[0], problem.starts[0])
    np.testing.assert_array_equal(calls[1], problem.starts[2])
    first, second = outcome.starts[0], outcome.starts[1]
    assert (second.index, second.status, second.return_status, second.objective,
            second.iterations, second.feasible, second.exchange_points) == (
        1, first.status, first.return_status, first.objective, first.iterations,
        first.feasible, first.exchange_points)
    # what running start 2 gives: a fresh problem whose only start is that point
    alone = _free_problem(3)
    alone.starts = alone.starts[1:2]
    again = alone.solve()
    assert (again.starts[0].objective, again.starts[0].iterations) == (
        second.objective, second.iterations)
    assert again.values == outcome.values
    assert [index for index, _ in outcome.equal_optima] == [0, 1, 2]


@pytest.mark.parametrize("limit", ["Maximum_WallTime_Exceeded", "Maximum_CpuTime_Exceeded"])
def test_a_start_that_ran_out_of_time_is_run_again(limit):
    """A run that a time limit stopped (IPOPT's wall-clock or CPU limit) is not taken over:
    the clock, not the iterates, ended it."""
    problem = _free_problem(2)
    calls = []

    def timed_out(start, started, hessian, resume=None):
        calls.append(start)
        problem._last_state = None
        return start, limit, 3, 0, None

    problem._solve_from = timed_out
    outcome = problem.solve()
    assert len(calls) == 2
    assert [s.return_status for s in outcome.starts] == [limit] * 2


def test_a_start_whose_first_attempt_ran_out_of_time_is_run_again():
    """The limited-memory attempt stopped by the clock, the exact one then solved: the
    run still depends on the clock, so a start from the same point runs again."""
    problem = _free_problem(2)
    problem.hessians = ["limited-memory", "exact"]
    calls = []
    solve_from = problem._solve_from

    def first_timed_out(start, started, hessian, resume=None):
        calls.append(hessian)
        if hessian == "limited-memory":
            problem._last_state = None
            return start, "Maximum_WallTime_Exceeded", 3, 0, None
        return solve_from(start, started, hessian, resume)

    problem._solve_from = first_timed_out
    outcome = problem.solve()
    assert calls == ["limited-memory", "exact"] * 2
    assert outcome.success and [s.status for s in outcome.starts] == ["optimal"] * 2
