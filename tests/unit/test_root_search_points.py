"""The root search's points (feedtune.tuner.roots): each z evaluated once per search, a
point read from the check's result arrays with the grid's bits, and the start's verdict
without the stability block (feedtune.tuner.stability.holds).

The search's answers are pinned by tests/unit/test_root_search.py and
test_root_search_along.py (IPOPT as the reference); here only that the work done once is
the same numbers as the work it replaces, to the bit.
"""

from __future__ import annotations

import copy
import math
from collections import Counter

import casadi as ca
import numpy as np
import pytest

from feedtune.problem import tune
from feedtune.schema.spec import parse_spec
from feedtune.tuner import roots
from feedtune.tuner.calls import numeric
from feedtune.tuner.stability import feasibility, holds
from feedtune.tuner.types import Bound

from test_root_search import SAMPLED
from test_root_search_along import ENCODER, tuned_problem


def _searches(data: dict, monkeypatch) -> list:
    """(search, Counter of the z it evaluated one at a time) of every root search made
    while ``data`` is tuned."""
    made = []
    for_problem = roots.RootSearch.for_problem

    def spy(problem, held=None, axis=0, check=None):
        search = for_problem(problem, held=held, axis=axis, check=check)
        if search is not None:
            counts, evaluate = Counter(), search.evaluate

            def counted(z):
                counts[(float(z), math.copysign(1.0, z))] += 1
                return evaluate(z)

            search.evaluate = counted
            made.append((search, counts))
        return search

    monkeypatch.setattr(roots.RootSearch, "for_problem", spy)
    tune(parse_spec(copy.deepcopy(data)))
    return made


@pytest.mark.parametrize("data", [SAMPLED, ENCODER], ids=["one-tunable", "along-lines"])
def test_each_z_is_evaluated_once_per_search(data, monkeypatch):
    """No z is evaluated twice by one search, and no grid point again on its own (brentq's
    bracket ends are grid points: before, each was evaluated again), while the searches
    count every value of e they read, as before."""
    made = _searches(data, monkeypatch)
    assert made and any(counts for _, counts in made)  # brentq ran
    for search, counts in made:
        assert max(counts.values(), default=1) == 1
        assert not set(counts) & {(z, math.copysign(1.0, z)) for z in search.grid.tolist()}
        assert search.evaluations >= len(search.grid) + sum(counts.values())


def test_a_point_is_the_grids_bits(monkeypatch):
    """ErrorCheck.point (one evaluation, read from the result arrays as Python floats) at
    every grid point of a line is the grid's mapped call's point, bit for bit, and the check
    Function's own outputs."""
    problem = tuned_problem(ENCODER, monkeypatch)
    check = roots.ErrorCheck(problem)
    held = np.asarray(problem.starts[1], dtype=float)
    grid = np.repeat(held[:, None], 9, axis=1)
    grid[1] = np.linspace(problem.lbw[1], problem.ubw[1], 9)
    mapped = check.points(grid)
    function = numeric(problem.evaluator.function)
    for column, point in zip(grid.T, mapped):
        one = check.point(column.copy())
        assert repr(one) == repr(point)
        outputs = function.outputs(column, problem.param_values[:problem.evaluator.n_params])
        assert one[0] == outputs[0][0, 0] or (math.isnan(one[0]) and math.isnan(outputs[0][0, 0]))


def test_nonzeros_are_the_outputs_entries():
    """NumericCall.nonzeros gives a dense output's entries column-major, the bits of
    :meth:`outputs`, in the thread's own result arrays (the same objects call after call)."""
    x = ca.MX.sym("x", 2)
    p = ca.MX.sym("p", 3)
    function = ca.Function("f", [x, p], [ca.vertcat(ca.sin(x[0]) * p[0], x[1] / p[2]),
                                         ca.horzcat(x * p[1], ca.exp(x))])
    call = numeric(function)
    rng = np.random.default_rng(3)
    first = None
    for _ in range(20):
        a, b = rng.normal(size=2), rng.normal(size=3) + 2.0
        full = call.outputs(a, b)
        flat = call.nonzeros(a, b)
        first = first or flat
        assert all(out is kept for out, kept in zip(flat, first))
        for dense, entries in zip(full, flat):
            assert dense.ravel(order="F").tobytes() == entries.tobytes()
    assert call.dense(0) and call.dense(1)


@pytest.mark.parametrize("discrete", [False, True])
def test_holds_is_feasibilitys_verdict(discrete):
    """stability.holds (no poles' list) says what feasibility(...)[0] says: on 400 random
    2 × 2 and 3 × 3 matrices around the stability boundary, with bounds held and not."""
    rng = np.random.default_rng(7)
    bounds = [Bound(label="b", value=abs, lower=0.5, upper=2.0)]
    agree = Counter()
    for _ in range(400):
        n = int(rng.integers(2, 4))
        matrix = rng.normal(size=(n, n)) * (0.6 if discrete else 1.0)
        if not discrete:
            matrix -= np.eye(n) * rng.uniform(0, 1.5)
        conditions = rng.normal(size=3) + 1.5
        value = [float(rng.uniform(0.0, 2.5))]
        matrices = {"closed_loop": matrix, "inner": rng.normal(size=(1, 1)) - 0.5}
        expected = feasibility(value, bounds, conditions, matrices, discrete)[0]
        assert holds(value, bounds, conditions, matrices.values(), discrete) == expected
        agree[expected] += 1
    assert agree[True] > 20 and agree[False] > 20
    assert not holds([], [], np.ones(1), [np.array([[np.nan]])], discrete)
