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
