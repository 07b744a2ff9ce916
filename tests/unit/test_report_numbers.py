"""A tuned design's reports as numbers, not graphs of constants (issue 15, branch h-bev3).

A loop of numbers' peaks and crossings are located in floats (``feedtune.loops.frequency``);
from a structure's second loop on they are returned as numbers (DM), the log grid of a band
is computed once, the golden and bisection folds are one straight SX graph, and the
reports' one Function evaluates only the expressions. Each must leave every number's
bits as they were (the batch's 300 result files are compared field by field in
``benchmarks/batch_throughput.py``); here on Koren's loops at seeded points of their box.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

import feedtune.loops.frequency as frequency
from feedtune import problem
from feedtune.objectives.frequency import frequency_domain
from feedtune.problem import Reports
from example_loops import KINDS, example_loops


def _loops(kind, count=3):
    """``count`` loops of numbers at seeded log-uniform points of the example's box."""
    return example_loops(kind, count, seed=27)


def test_a_bands_grid_is_computed_once_and_handed_out_as_a_copy(monkeypatch):
    band = (0.123, 4.56e5)
    count = int(np.ceil(np.log10(band[1] / band[0]) * frequency.POINTS_PER_DECADE)) + 1
    expected = np.geomspace(*band, count)
    first = frequency.log_grid(band)
    assert np.array_equal(first, expected)
    monkeypatch.setattr(np, "geomspace", lambda *args, **kwargs: pytest.fail("computed again"))
    first[0] = -1.0  # the caller's copy: the grid kept is untouched
    again = frequency.log_grid(band)
    assert np.array_equal(again, expected) and again is not first
    assert np.array_equal(frequency._log_of_grid(band), np.log(expected))
    assert not frequency._log_of_grid(band).flags.writeable


@pytest.mark.parametrize("kind", KINDS)
def test_a_structures_replayed_peak_and_crossing_are_numbers_with_the_graphs_bits(kind):
    """The first loop's peak and crossing are MX graphs of its numbers; a second loop of
    the structure gets DM numbers, equal to the graph its values would have given."""
    frequency._replays.clear()
    first, *others = _loops(kind)
    gain = frequency_domain.normalised_gain_squared
    crossing = frequency_domain.log_open_loop_gain_squared
    frequency.peak(gain(first), first.frequency_band, "test_numbers")
    frequency.crossing_if_any(crossing(first), first.frequency_band, 0.0, "test_numbers_x")
    for loop in others:
        replayed = (*frequency.peak(gain(loop), loop.frequency_band, "test_numbers"),
                    *frequency.crossing_if_any(crossing(loop), loop.frequency_band, 0.0,
                                               "test_numbers_x"))
        assert all(isinstance(v, ca.DM) for v in replayed)
        # the same loop with no replayed Functions: the floats' steps, as graphs
        frequency._replays.clear()
        loop.__dict__.pop("_parametric_twin", None)
        graphs = (*frequency.peak(gain(loop), loop.frequency_band, "test_numbers"),
                  *frequency.crossing_if_any(crossing(loop), loop.frequency_band, 0.0,
                                             "test_numbers_x"))
        assert [float(v) for v in replayed] == [float(ca.evalf(v)) for v in graphs]
        frequency.peak(gain(loop), loop.frequency_band, "test_numbers")  # asked again
        frequency.crossing_if_any(crossing(loop), loop.frequency_band, 0.0, "test_numbers_x")


def test_a_crossing_as_a_number_is_a_float_for_the_response_at_it():
    assert frequency_domain.as_number(ca.DM(12.5)) == 12.5
    assert isinstance(frequency_domain.as_number(ca.DM(12.5)), float)


def test_the_folds_are_one_sx_graph_with_the_bits_of_the_float_steps():
    loop = _loops("sampled", 1)[0]
    frequency._replays.clear()
    (f, _, _), _ = frequency.replayed("test_fold", frequency_domain.normalised_gain_squared(loop), 2)
    grid = np.log(frequency.log_grid(loop.frequency_band))
    h = (grid[1] - grid[0]) / 2
    a, b = np.fmax(grid - 2 * h, grid[0]), np.fmin(grid + 2 * h, grid[-1])
    floats = frequency._golden_steps_of_numbers(f, 42, a, b, f(grid))
    for _ in range(frequency.DERIVED_AFTER - 1):  # floats until the build
        frequency._golden_steps_of_numbers(f, 42, a, b, f(grid))
    folded = frequency._golden_steps_of_numbers(f, 42, a, b, f(grid))
    assert f._derived["golden", 42][1].fn.is_a("SXFunction")
    for x, y in zip(floats[:3], folded[:3]):
        assert np.array_equal(x, y)


class _Constant:
    """A metric whose value on any loop is ``value`` (a number or an expression)."""

    name = "constant"

    def __init__(self, value):
        self.value = value

    def evaluate(self, loop, options):
        return self.value


def test_reports_that_are_numbers_are_kept_without_the_reports_function(monkeypatch):
    sets = {"a": (_Constant(ca.DM(1.5)), None), "b": (_Constant(ca.MX(2.0) * 3), None),
            "c": (_Constant(0.25), None), "d": (_Constant(ca.MX(7.0) + 1), None)}
    built = []
    function = ca.Function
    monkeypatch.setattr(problem.ca, "Function",
                        lambda name, *args: built.append(args) or function(name, *args))
    values = Reports(sets)._evaluate_all(object())
    assert list(values) == ["a", "b", "c", "d"]
    assert [float(v) for v in values.values()] == [1.5, 6.0, 0.25, 8.0]
    assert len(built) == 1 and len(built[0][1]) == 2  # the two expressions only
    built.clear()
    numbers = {key: (_Constant(ca.DM(i)), None) for i, key in enumerate("xyz")}
    assert [float(v) for v in Reports(numbers)._evaluate_all(object()).values()] == [0, 1, 2]
    assert built == []


@pytest.mark.parametrize("kind", KINDS)
def test_loops_of_a_structure_share_its_structure_object(kind):
    """The replayed Functions' keys hold the structure: the one kept with the twin, so a
    look-up compares it by identity, not element by element."""
    from feedtune.loops.twin import parametric_twin

    first, second, _ = _loops(kind)
    a, b = parametric_twin(first), parametric_twin(second)
    assert a.structure == b.structure and a.structure is b.structure
