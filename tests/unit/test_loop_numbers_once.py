"""A loop of numbers evaluates its characteristic polynomial and its state matrix once,
for every reader (issue 15, branch h-bev7): the stability conditions, the damping ratio,
the step integrals' stability check and the tuned design's stability matrices, each with
the bits of its own evaluation of the graph before."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from example_loops import example_loops

import feedtune.loops.loop as loop_module
from feedtune.loops import linalg
from feedtune.objectives import METRICS


def _bits(values) -> list[str]:
    """Each number's hex form: equal bits, signed zeros told apart."""
    return [float(v).hex() for v in np.asarray(values, dtype=float).ravel()]


@pytest.mark.parametrize("kind", ["pulse", "sampled"])
def test_the_closed_loops_stability_matrix_is_its_numbers_with_evalfs_bits(kind):
    for loop in example_loops(kind, 4, seed=5):
        matrix = loop.stability_matrices()["closed_loop"]
        assert isinstance(matrix, ca.DM)  # it was the MX graph, evaluated again by the tuner
        assert _bits(matrix) == _bits(ca.evalf(ca.MX(loop.state_matrix)))
        assert _bits(matrix) == _bits(loop.numeric_state_matrix())


def test_a_continuous_loop_of_numbers_evaluates_its_matrix_and_polynomial_once(monkeypatch):
    loops = example_loops("pulse", 4, seed=9)
    expected = []
    for loop in loops:  # what the loop computed before: the MX graphs, each evaluated on its own
        _, a1, a0 = loop.characteristic_polynomial
        poly = [float(ca.evalf(ca.MX(c))) for c in loop.characteristic_polynomial]
        expected.append((float(ca.evalf(a1 / (2 * ca.sqrt(a0)))),
                         linalg.hurwitz_conditions_of_numbers(poly)))
    built = []
    original = loop_module._numbers
    # the graph's path (a structure's later loops read the twin's Function instead, with
    # these bits: tests/unit/test_twin_numbers.py)
    monkeypatch.setattr(loop_module, "replayed_numbers", lambda *args: None)
    monkeypatch.setattr(loop_module, "_numbers",
                        lambda values: built.append(len(values)) or original(values))
    for loop, (zeta, conditions) in zip(loops, expected):
        built.clear()
        damping = loop.damping_ratio()
        assert isinstance(damping, ca.DM) and _bits(damping) == _bits([zeta])
        assert _bits(loop.stability_conditions()) == _bits(conditions)
        assert loop.step_error_integrals.iae is not None
        assert _bits(loop.numeric_state_matrix()) == _bits(ca.evalf(ca.MX(loop.state_matrix)))
        assert built == [4]  # one evaluation of the matrix and the three coefficients


def test_a_loop_of_symbols_keeps_its_graphs():
    loop = example_loops("pulse", 1, seed=2)[0]
    gain = ca.MX.sym("gain")
    symbolic = type(loop)(loop.state_matrix * gain, loop.input_matrix, loop.position_row,
                          loop.velocity_constant * gain, loop.drive)
    assert isinstance(symbolic.stability_matrices()["closed_loop"], ca.MX)
    assert isinstance(symbolic.damping_ratio(), ca.MX)
    assert all(isinstance(c, ca.MX) for c in symbolic.stability_conditions())


@pytest.mark.parametrize("kind", ["pulse", "sampled"])
def test_the_pole_metrics_of_a_loop_of_numbers_are_numbers(kind):
    """Their exact values are DMs (they were MX constants, for which the reports' one Function
    was built on a sampled loop, whose other reports are all numbers), the same numbers."""
    for loop in example_loops(kind, 3, seed=13):
        for name in ("pole_damping", "decay_rate"):
            region = METRICS[name]().evaluate(loop, None)
            assert isinstance(region.exact, ca.DM)
            numbers = np.append(loop.numeric_state_matrix().ravel(order="F"),
                                float(loop.period) if loop.discrete else 0.0)
            assert _bits(region.exact) == _bits([region.measure(numbers)])
