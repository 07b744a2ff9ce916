"""feedtune.tuner.starts: deterministic starts in the logarithms of the tunables."""

import math

import numpy as np

from feedtune.tuner.starts import starting_points
from feedtune.tuner.types import Variable


def test_first_start_is_the_initial_point_or_the_geometric_middle():
    variables = [Variable("a", 1.0, 100.0, initial=5.0), Variable("b", 1e-4, 1e-2)]
    points = starting_points(variables, 1)
    np.testing.assert_allclose(points, [[math.log(5.0), math.log(1e-3)]])


def test_further_starts_are_deterministic_and_inside_the_box():
    variables = [Variable("a", 1.0, 100.0), Variable("b", 1e-4, 1e-2)]
    points = starting_points(variables, 8)
    assert points.shape == (8, 2)
    np.testing.assert_array_equal(points, starting_points(variables, 8))
    lower, upper = np.log([1.0, 1e-4]), np.log([100.0, 1e-2])
    assert np.all(points >= lower) and np.all(points <= upper)
    assert len({tuple(p) for p in points}) == 8
    # Halton's second point (its first is the box's corner) is (1/2, 1/3) of the box
    np.testing.assert_allclose(points[1], lower + [0.5, 1 / 3] * (upper - lower))


def test_no_variables_one_empty_start():
    assert starting_points([], 8).shape == (1, 0)


def test_halton_points_are_scipys_and_set_up_once_per_dimension(monkeypatch):
    """The points are scipy's unscrambled Halton sequence to the bit, and scipy's sequence
    object (≈ 0.5–1 ms to set up, as much as a batch spec's restoration checks) is made
    once per dimension and count, not once per problem."""
    from scipy.stats import qmc

    variables = [Variable("a", 1.0, 100.0), Variable("b", 1e-4, 1e-2), Variable("c", 2.0, 3.0)]
    lower, upper = np.log([1.0, 1e-4, 2.0]), np.log([100.0, 1e-2, 3.0])
    unit = qmc.Halton(3, scramble=False).random(5)[1:]
    np.testing.assert_array_equal(starting_points(variables, 5)[1:],
                                  lower + unit * (upper - lower))
    made = []
    original = qmc.Halton

    def counted(*args, **kwargs):
        made.append(args)
        return original(*args, **kwargs)

    monkeypatch.setattr(qmc, "Halton", counted)
    first = starting_points(variables, 5)
    first[1, 0] = 0.0  # the caller's copy: the cached points stay as they were
    np.testing.assert_array_equal(starting_points(variables, 5)[1:],
                                  lower + unit * (upper - lower))
    assert made == []
