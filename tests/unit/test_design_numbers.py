"""A tuned design's reports on numbers, without graphs of constants or DM calls (issue 15,
branch h-bev4).

A sampled loop of numbers computes its characteristic polynomial on DM, reads its hold
matrices in one Function, and sums its step integrals through the folds' evaluation
buffers; a continuous loop's pole metrics build their balanced polynomial only when a
condition row is asked for. Each must leave every number's bits as they were (the
batch's 300 result files are compared field by field in
``benchmarks/batch_throughput.py``); here on Koren's loops at seeded points of their box,
against what the previous code computed.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

import feedtune.loops.loop as loop_module
from feedtune.lazy import ca as lazy_ca
from feedtune.loops import linalg
from feedtune.objectives import METRICS
from feedtune.objectives.poles import pole_region
from example_loops import example_loops


def _bits(values) -> list[str]:
    """Each number's hex form: equal bits, signed zeros told apart."""
    return [float(v).hex() for v in np.asarray(values, dtype=float).ravel()]


@pytest.fixture
def sampled_loops():
    return example_loops("sampled", 4, seed=31)


def test_a_sampled_loop_of_numbers_has_its_polynomial_as_numbers_with_the_graphs_bits(sampled_loops):
    for loop in sampled_loops:
        poly = loop.characteristic_polynomial
        assert all(isinstance(c, ca.DM) for c in poly)  # main: MX graphs of constants
        graph = [ca.evalf(ca.MX(c)) for c in linalg.characteristic_polynomial(loop.state_matrix)]
        assert _bits(poly) == _bits(graph)


def test_a_sampled_loop_of_numbers_reads_its_hold_matrices_without_an_evalf_each(
        sampled_loops, monkeypatch):
    expected = [[np.array(ca.evalf(ca.MX(v)), dtype=float) for v in (*loop._matrices,
                                                                       loop.period)]
                for loop in sampled_loops]
    monkeypatch.setattr(lazy_ca, "evalf", lambda *a: pytest.fail("one evalf a matrix"))
    for loop, (phi, gamma, kx, kr, period) in zip(sampled_loops, expected):
        hold = loop.numeric_hold()
        assert _bits(hold[0]) == _bits(phi) and _bits(hold[1]) == _bits(gamma)
        assert _bits(hold[2]) == _bits(kx) and _bits(hold[3:5]) == _bits([kr, period])
        assert hold[5] == loop.plant.time_constant


def _integral_by_dm_calls(loop, name: str):
    """The step integral as main summed it: each fold of 2^k samples called with DM."""
    n = loop.order
    phi, gamma, kx, kr, period, tau = (ca.evalf(ca.MX(m)) for m in (
        *loop._matrices, loop.period, loop.plant.time_constant))
    final = ca.DM.zeros(n + 2)
    for k in loop_module._binary_chunks(loop.horizon_samples):
        final = loop_module._sample_fold(n, name, k)(final, phi, gamma, kx, kr, period, tau)
    tail = loop_module._tail(n, name)(final[:n], final[n + 1], phi, gamma, kx, period, tau)
    return final[n] + (tail if name == "ise" else ca.fabs(tail))


def test_a_loop_of_numbers_sums_its_step_integrals_through_buffers_with_the_dm_calls_bits(
        sampled_loops, monkeypatch):
    expected = [[_integral_by_dm_calls(loop, name) for name in ("iae", "ise", "itae")]
                for loop in sampled_loops]
    fresh = example_loops("sampled", 4, seed=31)  # the same loops, nothing cached on them
    monkeypatch.setattr(ca.Function, "__call__",
                        lambda *a, **k: pytest.fail("a fold called with DM"))
    for loop, values in zip(fresh, expected):
        integrals = loop.step_error_integrals
        got = [integrals.iae, integrals.ise, integrals.itae]
        assert all(isinstance(v, ca.DM) for v in got)
        assert _bits(got) == _bits(values)


def test_a_continuous_loops_pole_metrics_build_their_conditions_basis_only_when_asked(
        monkeypatch):
    built = []
    balanced = pole_region._balanced
    monkeypatch.setattr(pole_region, "_balanced", lambda poly: built.append(1) or balanced(poly))
    for loop in example_loops("pulse", 3, seed=31):
        for name in ("pole_damping", "decay_rate"):
            region = METRICS[name]().evaluate(loop, None)
            assert np.isfinite(float(ca.evalf(region.exact)))
        assert not built  # main: the balanced polynomial built three times a loop
        poly = loop.characteristic_polynomial
        eager, omega0 = balanced(poly)
        damping = pole_region.damping_conditions(loop)
        decay = pole_region.decay_conditions(loop)
        rows = [*damping(0.4), *damping(0.6), *decay(5.0)]
        assert len(built) == 2  # once per closure, however many levels it is asked at
        expected = [*pole_region.routh_column(pole_region.rotated_product(
                        eager, ca.asin(ca.fmin(0.4, 1)))),
                    *pole_region.routh_column(pole_region.rotated_product(
                        eager, ca.asin(ca.fmin(0.6, 1)))),
                    *pole_region.routh_column(linalg.taylor_shift(eager, -5.0 / omega0))]
        assert _bits([ca.evalf(ca.MX(r)) for r in rows]) == _bits(
            [ca.evalf(ca.MX(r)) for r in expected])
        built.clear()
