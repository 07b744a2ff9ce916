"""feedtune.tuner.starts: deterministic starts in the logarithms of the tunables."""

import math
import subprocess
import sys

import numpy as np
import pytest

from feedtune.tuner.starts import _halton, starting_points
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


@pytest.mark.parametrize("lower, initial", [(1.0, None), (0.5, None), (1.0, math.sqrt(4.9))])
def test_a_start_at_the_first_is_skipped(lower, initial):
    """One tunable whose first start is the box's middle (no ``initial``, or that one):
    Halton's first point after the corner, 1/2 of the box, is that start again (to the bit
    for a lower bound of 1, to the last bits otherwise), so it is skipped and the eight
    starts are eight points, Halton's 1/4, 3/4, 1/8, … after the middle."""
    upper = 4.9 if lower == 1.0 else 9.8
    points = starting_points([Variable("k", lower, upper, initial=initial)], 8)[:, 0]
    low, high = math.log(lower), math.log(upper)
    assert len(points) == 8
    assert min(np.diff(np.sort(points))) > (high - low) / 100
    assert points[0] == pytest.approx((low + high) / 2, abs=1e-12)
    np.testing.assert_allclose(points[1:4], low + np.array([0.25, 0.75, 0.125]) * (high - low),
                               rtol=0, atol=1e-12)


def test_no_variables_one_empty_start():
    assert starting_points([], 8).shape == (1, 0)


def test_halton_points_are_scipys_and_set_up_once_per_dimension():
    """The points are scipy's unscrambled Halton sequence to the bit, made once per
    dimension and count, not once per problem; the caller gets a copy."""
    from scipy.stats import qmc

    variables = [Variable("a", 1.0, 100.0), Variable("b", 1e-4, 1e-2), Variable("c", 2.0, 3.0)]
    lower, upper = np.log([1.0, 1e-4, 2.0]), np.log([100.0, 1e-2, 3.0])
    unit = qmc.Halton(3, scramble=False).random(5)[1:]
    np.testing.assert_array_equal(starting_points(variables, 5)[1:],
                                  lower + unit * (upper - lower))
    first = starting_points(variables, 5)
    first[1, 0] = 0.0  # the caller's copy: the cached points stay as they were
    np.testing.assert_array_equal(starting_points(variables, 5)[1:],
                                  lower + unit * (upper - lower))
    assert _halton(3, 5) is _halton(3, 5)


@pytest.mark.parametrize("dimension", [1, 2, 5, 8, 13, 24])
def test_halton_sequence_is_scipys_to_the_bit(dimension):
    """Every point up to 257 (bases up to 89, digits in several places) equals scipy's
    ``qmc.Halton(d, scramble=False)`` exactly: the same starts, so the same tunings."""
    from scipy.stats import qmc

    np.testing.assert_array_equal(_halton(dimension, 257),
                                  qmc.Halton(dimension, scramble=False).random(257)[1:])


def test_multistart_does_not_import_scipy_stats():
    """The starts need no ``scipy.stats`` (0.2–0.5 s of imports a process)."""
    code = ("import sys; from feedtune.tuner.starts import _halton, starting_points;"
            "from feedtune.tuner.types import Variable;"
            "starting_points([Variable('a', 1.0, 100.0), Variable('b', 1e-4, 1e-2)], 8);"
            "print('scipy.stats' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "False"
