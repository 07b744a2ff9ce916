"""feedtune.tuner.supremum: peaks over frequency held by the exchange method.

A toy loop with one tunable k and the peak k·ω/(1 + ω²) (largest value k/2 at ω = 1 rad/s):
on a grid that misses ω = 1 the grid alone would allow a larger k than the true bound.
"""

import math

import casadi as ca
import numpy as np
import pytest

from feedtune.expr import Supremum
from feedtune.frequency import peak
from feedtune.tuner.builder import NlpBuilder
from feedtune.tuner.nlp import Problem
from feedtune.tuner.supremum import (EXCHANGE_POINTS, EXCHANGE_TOL, ExchangeGroup,
                                     add_exchange_points, supremum_below)
from feedtune.tuner.types import Bound, Settings, Term, Variable

GRID = np.array([0.1, 0.5, 2.0, 10.0])  # rad/s; the peak at 1 rad/s falls between points


class ToyLoop:
    """Stable for every k > 0; no horizon, no inner loop."""

    discrete = False
    unrolled_steps = 0

    def __init__(self, k):
        self.k = k

    def stability_conditions(self):
        return [self.k]

    def settling_conditions(self):
        return []

    def stability_matrices(self):
        return {"closed_loop": ca.reshape(-self.k, 1, 1)}


def toy_peak(loop):
    def fn(omega):
        return loop.k * omega / (1 + omega**2)

    value, where = peak(fn, (0.01, 100.0))
    return Supremum(fn, GRID, value, where)


def test_the_exchange_method_holds_the_true_peak_not_the_grid():
    """max k s.t. peak ≤ 1: on the grid alone k = 1/0.4 = 2.5; the true answer is k = 2."""
    problem = Problem([Variable("k", 0.1, 10.0, initial=1.0)], {},
                      lambda values: ToyLoop(values["k"]),
                      [Term("k", lambda loop: loop.k, -1.0)],
                      [Bound("peak", toy_peak, None, 1.0)], {}, Settings(multistart=1))
    outcome = problem.solve()
    assert outcome.success, outcome.message
    assert outcome.values["k"] == pytest.approx(2.0, rel=1e-6)
    assert outcome.constraints[0][1] == pytest.approx(1.0, rel=1e-6)
    assert outcome.starts[0].exchange_points >= 1


def test_grid_rows_then_exchange_rows_switched_off():
    builder = NlpBuilder([Variable("k", 0.1, 10.0)])
    loop = ToyLoop(ca.exp(builder.z[0]))
    groups = []
    supremum_below(builder, toy_peak(loop), 1.0, 1.0, True, groups)
    assert len(builder.rows) == len(GRID) + EXCHANGE_POINTS
    assert np.all(builder.ubg[:len(GRID)] == 0) and np.all(builder.ubg[len(GRID):] == np.inf)
    group = groups[0]
    assert group.rows == list(range(len(GRID), len(GRID) + EXCHANGE_POINTS))
    check = ca.Function("check", [builder.z], [group.violation, group.where])
    violation, where = (float(v) for v in check(math.log(3.0)))
    assert violation == pytest.approx(0.5, rel=1e-9)  # peak 1.5 over the bound 1
    assert where == pytest.approx(1.0, rel=1e-9)


def _group():
    return ExchangeGroup((-np.inf, 0.0), slots=[0, 1], rows=[5, 6])


def test_a_violated_group_switches_on_its_next_row():
    slots, lbg, ubg = np.zeros(2), np.full(7, -np.inf), np.full(7, np.inf)
    used = [0]
    assert add_exchange_points([_group()], np.array([0.1]), np.array([3.0]), slots, lbg, ubg,
                               used) is True
    assert used == [1] and slots[0] == 3.0 and ubg[5] == 0.0 and ubg[6] == np.inf


@pytest.mark.parametrize("violation, where", [(EXCHANGE_TOL / 2, 3.0), (1.0, math.nan),
                                              (1.0, 0.0)])
def test_no_point_for_a_tiny_violation_or_no_frequency(violation, where):
    slots, lbg, ubg = np.zeros(2), np.full(7, -np.inf), np.full(7, np.inf)
    assert add_exchange_points([_group()], np.array([violation]), np.array([where]), slots, lbg,
                               ubg, [0]) is False
    assert np.all(ubg == np.inf)


def test_a_group_out_of_points_says_so():
    slots, lbg, ubg = np.zeros(2), np.full(7, -np.inf), np.full(7, np.inf)
    assert add_exchange_points([_group()], np.array([0.1]), np.array([3.0]), slots, lbg, ubg,
                               [2]) is None
