"""The multistart stops when no later start could replace the best (issue 15's batch).

A start is chosen over an earlier one only when its objective is lower by more than
:meth:`Problem._better`'s tie (1e-9, relative above 1); an objective that is a sum of |e|
terms with positive weights is never below 0. So once a one-tunable problem's best start
is within that tie of 0, every later start would leave it chosen: those starts are not run,
and the tuned values are the ones running them would have given, to the bit.
"""

import math

import casadi as ca
import pytest

from feedtune.expr import Magnitude
from feedtune.tuner.nlp import Problem
from feedtune.tuner.types import Settings, Term, Variable

#: IPOPT named, so a one-tunable problem is solved by IPOPT's starts, not the scalar search
SETTINGS = {"ipopt_options": {"hessian_approximation": "exact"}}


class Loop:
    """A stable toy loop (pole −1 [1/s]) whose metrics read the tunables directly."""

    discrete = False
    unrolled_steps = 0

    def __init__(self, values):
        self.values = values

    def stability_conditions(self):
        return [ca.MX(1.0)]

    def settling_conditions(self):
        return []

    def embedded_reads(self):
        return frozenset()  # no embedded numbers (Loop protocol)

    def stability_matrices(self):
        return {"closed_loop": ca.MX(-1.0)}


def _problem(terms: list[Term], variables: list[Variable], starts: int = 4) -> Problem:
    problem = Problem(variables, {}, Loop, terms, [], {}, Settings(multistart=starts, **SETTINGS))
    assert problem.scalar is None
    return problem


K = Variable("k", 0.5, 4.9, initial=1.0)
#: |k − 2|: 0 at k = 2, an epigraph in the NLP
ZERO_AT_2 = Term("e", lambda loop: Magnitude(loop.values["k"] - 2))


def _all_starts(problem: Problem, monkeypatch):
    """The outcome with every start run (the stop switched off)."""
    with monkeypatch.context() as patch:
        patch.setattr(Problem, "_unbeatable", lambda self, key: False)
        return problem.solve()


def test_a_start_at_the_floor_ends_the_multistart(monkeypatch):
    outcome = _problem([ZERO_AT_2], [K]).solve()
    assert outcome.success
    assert [s.index for s in outcome.starts] == [0]
    assert "the last 3 of 4 starts were not run" in outcome.message
    assert math.isclose(outcome.values["k"], 2.0, rel_tol=1e-7)
    full = _all_starts(_problem([ZERO_AT_2], [K]), monkeypatch)
    assert [s.index for s in full.starts] == [0, 1, 2, 3]
    # the chosen start is the same: every tuned value and metric to the bit
    assert outcome.values == full.values
    assert outcome.objective == full.objective
    assert outcome.reports == full.reports
    assert outcome.flat_tunables == full.flat_tunables


@pytest.mark.parametrize("term", [
    # |(k − 2)² + 0.5|: a magnitude whose least value 0.5 is far above the tie
    Term("e", lambda loop: Magnitude((loop.values["k"] - 2) ** 2 + 0.5)),
    # (k − 2)²: 0 at its optimum, but not a magnitude: no lower bound known
    Term("e", lambda loop: (loop.values["k"] - 2) ** 2),
])
def test_every_start_runs_without_a_floor_reached(term):
    outcome = _problem([term], [K]).solve()
    assert outcome.success
    assert len(outcome.starts) == 4


def test_two_tunables_run_every_start():
    """|k − 2m| is 0 along a line: the other starts show it (the result's spread)."""
    m = Variable("m", 0.5, 4.9, initial=1.5)
    outcome = _problem([Term("e", lambda loop: Magnitude(loop.values["k"] - 2 * loop.values["m"]))],
                       [K, m]).solve()
    assert outcome.success
    assert len(outcome.starts) == 4


def test_the_objective_floor_needs_magnitudes_with_weights_of_one_sign():
    plain = Term("f", lambda loop: loop.values["k"] ** 2)
    assert _problem([ZERO_AT_2], [K]).evaluator.objective_floor == 0.0
    assert _problem([ZERO_AT_2, plain], [K]).evaluator.objective_floor is None
    maximised = Term("e", ZERO_AT_2.value, weight=-1.0)
    assert _problem([maximised, Term("g", ZERO_AT_2.value, weight=2.0)],
                    [K]).evaluator.objective_floor is None
