"""feedtune.tuner.stability: the tuner's own eigenvalue verdict, feasibility, restoration."""

import math

import casadi as ca
import numpy as np

from feedtune.tuner.builder import NlpBuilder
from feedtune.tuner.stability import (POLE_MARGIN, STABILITY_MARGIN, add_stability_rows,
                                      feasibility, nan_where_unstable, poles_stable, restore)
from feedtune.tuner.types import Bound, Variable


def test_continuous_and_sampled_poles():
    stable = poles_stable(np.diag([-1.0, -2.0]), discrete=False)
    assert stable["stable"] and stable["domain"] == "s" and stable["spectral_abscissa"] == -1.0
    assert stable["poles"] == [[-2.0, 0.0], [-1.0, 0.0]]
    assert not poles_stable(np.diag([-1.0, 0.0]), discrete=False)["stable"]
    sampled = poles_stable(np.diag([0.5, -0.9]), discrete=True)
    assert sampled["stable"] and sampled["spectral_radius"] == 0.9
    assert not poles_stable(np.diag([1.0 - POLE_MARGIN / 2]), discrete=True)["stable"]
    assert not poles_stable(np.array([[np.nan]]), discrete=False)["stable"]


def test_each_pole_is_judged_against_its_own_magnitude():
    # a slow pole 1e-9 of the fast one's size is still stable (a stiff feed-drive loop)
    assert poles_stable(np.diag([-0.013, -1.8e7]), discrete=False)["stable"]


def test_feasibility_names_every_loop_and_needs_conditions_and_eigenvalues():
    bound = Bound("x", lambda loop: None, 1.0, None)
    matrices = {"closed_loop": np.diag([-1.0]), "inner_loop": np.diag([1.0])}
    ok, block = feasibility([2.0], [bound], np.array([1.0]), matrices, discrete=False)
    assert not ok and not block["stable"] and not block["inner_loop"]["stable"]
    assert block["conditions_hold"]
    matrices["inner_loop"] = np.diag([-3.0])
    assert feasibility([2.0], [bound], np.array([1.0]), matrices, False)[0]
    assert not feasibility([0.5], [bound], np.array([1.0]), matrices, False)[0]  # bound broken
    ok, block = feasibility([2.0], [bound], np.array([-1.0]), matrices, False)
    assert not ok and not block["conditions_hold"]


def test_stability_rows_are_asinh_of_scaled_conditions():
    builder = NlpBuilder([Variable("k", 0.1, 10.0)])
    condition = 1.0 - ca.exp(builder.z[0])  # stable for k < 1
    settling = add_stability_rows(builder, [condition], [], [1e3], [])
    assert settling == [] and builder.g.numel() == 1
    np.testing.assert_array_equal(builder.lbg, [STABILITY_MARGIN])
    row = ca.Function("row", [builder.z, builder.p], [builder.g])
    value = float(row(math.log(0.5), builder.param_values))
    assert math.isclose(value, math.asinh(0.5 / 1e3), rel_tol=1e-12)


def test_the_objective_is_nan_outside_the_stable_region():
    k = ca.MX.sym("k")
    f = ca.Function("f", [k], [nan_where_unstable(k**2, [1 - k, k + 5])])
    assert float(f(0.5)) == 0.25 and float(f(-2.0)) == 4.0
    assert math.isnan(float(f(1.0))) and math.isnan(float(f(2.0))) and math.isnan(float(f(-5)))
    assert nan_where_unstable(k, []) is k  # nothing to guard


def test_restoration_keeps_a_stable_start_and_moves_an_unstable_one():
    def evaluate(z):
        real = math.exp(z[0]) - 1.0  # poles real ± 1j: stable for k = exp(z) < 1
        return np.array([-real]), [np.array([[real, 1.0], [-1.0, real]])]

    lower, upper = np.array([math.log(0.1)]), np.array([math.log(10.0)])
    stable = np.array([math.log(0.5)])
    assert restore(stable, evaluate, lower, upper, discrete=False) is stable
    moved = restore(np.array([math.log(2.0)]), evaluate, lower, upper, discrete=False)
    assert moved is not None and math.exp(moved[0]) < 1.0


def test_restoration_gives_up_where_nothing_is_stable():
    def evaluate(z):
        return np.array([-1.0]), [np.array([[1.0 + math.exp(z[0])]])]

    assert restore(np.array([0.0]), evaluate, np.array([-1.0]), np.array([1.0]), False) is None
