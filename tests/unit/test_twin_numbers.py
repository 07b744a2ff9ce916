"""A loop of numbers' matrices read through one Function of its structure's twin numbers
(issue 15, branch h-bev9): a sampled loop's hold matrices (Φ, Γ, k_x, k_r, T, τ) and a
continuous loop's state matrix and characteristic polynomial, built at a structure's second
request and called with each loop's numbers, have the bits and sparsity of the graph of
its constants evaluated (`_numbers`), and a sampled loop's reports then build no graph of
its matrices."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from example_loops import example_loops

import feedtune.loops.loop as loop_module
import feedtune.loops.twin as twin_module
from feedtune.loops.twin import replayed_numbers
from feedtune.objectives import METRICS

#: what each kind of loop reads through the twin, as loop.py names it
READS = {"pulse": ("matrix_and_polynomial", loop_module._matrix_and_polynomial),
         "sampled": ("hold", loop_module._hold_values)}


def _bits(values) -> list[str]:
    """Each number's hex form: equal bits, signed zeros told apart."""
    return [float(v).hex() for v in np.asarray(values, dtype=float).ravel()]


def _same(replayed: list, expected: list) -> bool:
    return len(replayed) == len(expected) and all(
        isinstance(r, ca.DM) and r.sparsity() == e.sparsity() and _bits(r) == _bits(e)
        for r, e in zip(replayed, expected))


@pytest.mark.parametrize("kind", ["pulse", "sampled"])
def test_a_structures_later_loops_read_the_graphs_numbers_from_the_twin(kind):
    name, values_of = READS[kind]
    expected = [loop_module._numbers(values_of(loop)) for loop in example_loops(kind, 12, seed=61)]
    replayed = [replayed_numbers(loop, name, values_of) for loop in example_loops(kind, 12, seed=61)]
    assert all(r is not None for r in replayed[1:])  # the first may be the structure's first
    assert all(_same(r, e) for r, e in zip(replayed, expected) if r is not None)


def test_the_first_request_builds_nothing_and_a_loop_of_symbols_has_none():
    loops = example_loops("sampled", 2, seed=67)
    name = "test_the_first_request_builds_nothing"  # a key no other test asks for

    def kept():
        return [v for (n, _), v in twin_module._numbers_functions.items() if n == name]

    assert replayed_numbers(loops[0], name, loop_module._hold_values) is None
    assert kept() == []  # asked for once: nothing built
    assert _same(replayed_numbers(loops[1], name, loop_module._hold_values),
                 loop_module._numbers(loop_module._hold_values(loops[1])))
    assert [type(v) for v in kept()] == [ca.Function]
    loop = example_loops("pulse", 1, seed=2)[0]
    gain = ca.MX.sym("gain")
    symbolic = type(loop)(loop.state_matrix * gain, loop.input_matrix, loop.position_row,
                          loop.velocity_constant * gain, loop.drive)
    assert replayed_numbers(symbolic, "matrix_and_polynomial",
                            loop_module._matrix_and_polynomial) is None


def _reported(loop) -> list:
    values = []
    for name in ("damping_ratio", "pole_damping", "decay_rate", "iae", "ise", "itae",
                 "settling_time", "overshoot"):
        metric = METRICS[name]()
        value = metric.evaluate(loop, metric.Options())
        values.append(value.exact if name in ("pole_damping", "decay_rate") else value)
    values += list(loop.stability_conditions()) + [loop.stability_matrices()["closed_loop"]]
    return [_bits(ca.evalf(ca.MX(v)) if isinstance(v, ca.MX) else v) for v in values]


def test_a_sampled_loops_reports_build_no_graph_of_its_matrices(monkeypatch):
    """Every report that reads a sampled loop of numbers' matrices reads their numbers
    (before: the pole metrics and the step integrals built Φ's graph, and the hold's
    numbers were that graph evaluated), with the graph path's bits."""
    loops = [loop for loop in example_loops("sampled", 8, seed=71)
             if loop._numeric_spectral_radius < 1]
    assert len(loops) >= 3
    replayed = [_reported(loop) for loop in loops]
    assert all("_matrices" not in vars(loop) for loop in loops[1:])
    with monkeypatch.context() as patch:  # the graph's path, on the same points
        patch.setattr(loop_module, "replayed_numbers", lambda *args: None)
        expected = [_reported(loop) for loop in example_loops("sampled", 8, seed=71)
                    if loop._numeric_spectral_radius < 1]
    assert replayed == expected


def _reported_continuous(loop) -> list:
    values = []
    for name in ("iae", "ise", "itae"):
        metric = METRICS[name]()
        for time in ("absolute", "natural"):
            values.append(metric.evaluate(loop, metric.Options(time=time)))
    for name in ("damping_ratio", "natural_frequency", "velocity_constant"):
        metric = METRICS[name]()
        values.append(metric.evaluate(loop, metric.Options()))
    for name in ("pole_damping", "decay_rate"):
        metric = METRICS[name]()
        values.append(metric.evaluate(loop, metric.Options()).exact)
    values += list(loop.stability_conditions()) + [loop.stability_matrices()["closed_loop"]]
    return [_bits(ca.evalf(v) if isinstance(v, ca.MX) else v) for v in values]


def test_a_continuous_loops_reports_read_its_polynomial_from_the_twin(monkeypatch):
    """A structure's later loops take the characteristic polynomial from a call of the
    twin's Function in their graphs (before: the recursion's graph on their constants):
    every report the same bits, ITAE in natural time too (√c0 squared folds to c0 on both)."""
    loops = example_loops("pulse", 10, seed=73)
    replayed = [_reported_continuous(loop) for loop in loops]
    assert all(c.is_output() for loop in loops[2:] for c in loop.characteristic_polynomial)
    with monkeypatch.context() as patch:  # the graph's path, on the same points
        patch.setattr(loop_module, "replayed_numbers", lambda *args: None)
        patch.setattr(loop_module, "replayed_expressions", lambda *args: None)
        expected = [_reported_continuous(loop) for loop in example_loops("pulse", 10, seed=73)]
    assert replayed == expected
