"""The root search's grid read as arrays (feedtune.tuner.roots.GridPoints): the same
numbers, to the bit, as the points one by one that the search read before.

The search's answers are pinned by tests/unit/test_root_search.py and
test_root_search_along.py (IPOPT as the reference), the mapped call's bits against one
call a point by test_root_search_points.py; here only that the arrays, the feasibility
taken over them and the points read from them lazily are those points.
"""

from __future__ import annotations

import math

import numpy as np

from feedtune.tuner import roots

from test_root_search_along import ENCODER, tuned_problem


def _line(problem, axis: int, n: int = 9) -> np.ndarray:
    """A grid of ``n`` points along tunable ``axis`` through the problem's second start."""
    grid = np.repeat(np.asarray(problem.starts[1], dtype=float)[:, None], n, axis=1)
    grid[axis] = np.linspace(problem.lbw[axis], problem.ubw[axis], n)
    return grid


def test_the_arrays_are_the_points_one_by_one(monkeypatch):
    """Along each tunable of a two-tunable batch spec (the encoder's bound cuts the grid):
    e, the bound rows, the other conditions and the feasibility of every column are the
    point ErrorCheck.point gives there (repr: every float's bits), and its verdict."""
    problem = tuned_problem(ENCODER, monkeypatch)
    check = roots.ErrorCheck(problem)
    verdicts = []
    for axis in range(problem.n_z):
        grid = _line(problem, axis)
        points = check.points(grid)
        assert len(points) == grid.shape[1]
        feasible = points.feasible()
        for index, column in enumerate(grid.T):
            one = check.point(column.copy())
            assert repr(points[index]) == repr(one)
            assert repr(float(points.errors[index])) == repr(one[0])
            assert feasible[index] == roots._feasible(one)
        verdicts += feasible.tolist()
    assert any(verdicts) and not all(verdicts)


def test_points_evaluated_one_by_one_are_kept_as_given():
    """A search without a mapped call keeps each point as its ``evaluate`` gave it (rows an
    array here), and judges NaN, an infinite e and a violated row as before."""
    given = [(0.5, np.array([-1.0, -2.0]), -1.0), (math.nan, np.array([-1.0, -1.0]), -1.0),
             (math.inf, np.array([-1.0, -1.0]), -1.0), (0.1, np.array([0.5, -1.0]), -1.0),
             (0.1, np.array([-0.5, math.nan]), -1.0), (0.2, np.array([-1.0, -1.0]), 0.5),
             (-0.3, np.array([0.0, 0.0]), 0.0)]
    points = roots.GridPoints.of(given)
    assert [points[i] is p for i, p in enumerate(given)] == [True] * len(given)
    assert points.feasible().tolist() == [roots._feasible(p) for p in given]


def test_a_grid_point_is_read_not_evaluated(monkeypatch):
    """The search reads a grid point from the grid's arrays (no evaluation of its own), as
    the tuple the mapped call's column gives; a z off the grid is evaluated."""
    problem = tuned_problem(ENCODER, monkeypatch)
    check = roots.ErrorCheck(problem)
    search = roots.RootSearch.for_problem(problem, held=np.asarray(problem.starts[1]), axis=0,
                                          check=check)
    evaluated = []
    evaluate = search.evaluate
    search.evaluate = lambda z: evaluated.append(z) or evaluate(z)
    z = float(search.grid[3])
    full = np.asarray(problem.starts[1], dtype=float).copy()
    full[0] = z
    assert repr(search._at(z)) == repr(check.point(full))
    assert search._at(z) is search._at(z) and not evaluated
    search._at(z + 1e-3)
    assert evaluated == [z + 1e-3]


def test_the_lines_spacing_is_numpys_made_once(monkeypatch):
    """The evenly spaced z of a line are np.linspace's bits, made once per problem and box
    and shared (read-only) by the lines along that tunable."""
    problem = tuned_problem(ENCODER, monkeypatch)
    check = roots.ErrorCheck(problem)
    lower, upper = float(problem.lbw[1]), float(problem.ubw[1])
    spaced = check.spaced(lower, upper, roots.GRID_POINTS)
    assert spaced.tobytes() == np.linspace(lower, upper, roots.GRID_POINTS).tobytes()
    assert check.spaced(lower, upper, roots.GRID_POINTS) is spaced
    assert not spaced.flags.writeable
    held = np.asarray(problem.starts[2], dtype=float)
    search = roots.RootSearch.for_problem(problem, held=held, axis=1, check=check)
    alone = roots.RootSearch(search.evaluate, lower, upper, search.starts,
                             evaluate_all=search.evaluate_all)  # np.linspace made here
    assert search.grid.tobytes() == alone.grid.tobytes()
    assert search.errors.tobytes() == alone.errors.tobytes()
