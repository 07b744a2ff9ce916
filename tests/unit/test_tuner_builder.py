"""feedtune.tuner.builder: the NLP's pieces, collected with names."""

import math

import casadi as ca
import numpy as np
import pytest

from feedtune.tuner.builder import NlpBuilder, scale
from feedtune.tuner.types import Variable

VARIABLES = [Variable("gain", 1.0, 100.0), Variable("period", 1e-3, 1e-1)]


def test_variables_bounds_are_the_tunables_logarithms_then_the_auxiliary_ones():
    builder = NlpBuilder(VARIABLES)
    t = builder.variable("slack", 0.0, 5.0, builder.z[0] * 2)
    assert builder.n_z == 2 and builder.w.shape == (3, 1)
    np.testing.assert_allclose(builder.lbw, [0.0, math.log(1e-3), 0.0])
    np.testing.assert_allclose(builder.ubw, [math.log(100.0), math.log(1e-1), 5.0])
    assert builder.extra[0] is t


def test_a_vector_of_rows_gets_one_index_per_entry():
    builder = NlpBuilder(VARIABLES)
    builder.constrain(builder.z[0], 0.0, 1.0)
    rows = builder.constrain_all(ca.DM([[1.0, 2.0, 3.0]]) * builder.z[1], -1.0, 1.0)
    assert rows == range(1, 4) and len(builder.lbg) == 4
    g = ca.Function("g", [builder.z], [builder.g])
    np.testing.assert_allclose(np.asarray(g([0.0, 2.0])).ravel(), [0.0, 2.0, 4.0, 6.0])


def test_rows_parameters_and_slots_keep_their_order_and_indices():
    builder = NlpBuilder(VARIABLES)
    a = builder.parameter("a", 2.0)
    b = builder.parameter("b", 3.0)
    first = builder.constrain(a * builder.z[0], 0.0, 1.0)
    second = builder.constrain(b + builder.z[1], -ca.inf, 4.0)
    index, omega = builder.slot("exchange0", 7.5)
    third = builder.constrain(omega * builder.z[0], -ca.inf, ca.inf)
    assert (first, second, third, index) == (0, 1, 2, 0)
    np.testing.assert_array_equal(builder.param_values, [2.0, 3.0])
    np.testing.assert_array_equal(builder.slot_defaults, [7.5])
    np.testing.assert_array_equal(builder.lbg, [0.0, -np.inf, -np.inf])
    np.testing.assert_array_equal(builder.ubg, [1.0, 4.0, np.inf])
    g = ca.Function("g", [builder.z, ca.vertcat(*builder.slots), builder.p],
                    [builder.g])
    np.testing.assert_allclose(np.asarray(g([1.0, 2.0], [7.5], builder.param_values)).ravel(),
                               [2.0, 5.0, 7.5])


@pytest.mark.parametrize("candidates, expected", [
    ((None, 0.0, -3.0, 2.0), 3.0), ((None, math.inf, 0.0), 1.0), ((), 1.0)])
def test_scale_is_the_largest_finite_nonzero_magnitude(candidates, expected):
    assert scale(*candidates) == expected


def test_a_vector_of_rows_stays_one_vector_of_the_constraints():
    """A grid's rows enter the NLP as the vector they were built as, not one MX node per
    entry (560 of the user drive's 1 444 nodes, each differentiated again in every direction
    of an unexpanded Jacobian): the constraint graph does not grow with the rows, and the
    rows keep their order and values."""
    sizes = []
    for n in (3, 300):
        builder = NlpBuilder(VARIABLES)
        builder.constrain(builder.z[0], 0.0, 1.0)
        rows = builder.constrain_all(ca.DM(np.arange(1.0, n + 1)).T * builder.z[1], -1.0, 1.0)
        assert rows == range(1, n + 1) and builder.g.numel() == n + 1
        g = ca.Function("g", [builder.z], [builder.g])
        sizes.append(g.n_instructions())
        np.testing.assert_array_equal(np.asarray(g([0.5, 2.0])).ravel(),
                                      [0.5, *(2.0 * np.arange(1.0, n + 1))])
    assert sizes[1] == sizes[0]
