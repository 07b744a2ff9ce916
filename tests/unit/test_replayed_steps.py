"""The refinements of a structure's replayed Functions in a few calls (issue 15, branch h-bev2).

From a structure's third peak or crossing on (``frequency.DERIVED_AFTER``), the
golden-section steps of every window and the 32 bisection steps run as folded CasADi
Functions and f, f′, f″ as one jet
(``feedtune.loops.frequency.Mapped.derived``), and the radial error and the margins read
the loop's response at one ω through a Function replayed on the loop's twin
(``frequency.replayed_at``). Each must give the bits of the float steps and of the graph
built on the loop of numbers (the result files of a batch are compared field by field in
``benchmarks/batch_throughput.py``); here on Koren's two loops at seeded points of their
boxes, stable or not.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

import feedtune.loops.frequency as frequency
from feedtune.expr import Unbounded
from feedtune.objectives.contour.circle import CircleOptions
from feedtune.objectives.contour.radial_error import RadialError
from feedtune.objectives.frequency import frequency_domain
from feedtune.objectives.frequency.gain_margin import GainMargin
from feedtune.objectives.frequency.phase_margin import PhaseMargin
from feedtune.tuner.terms import exact_value
from example_loops import KINDS, example_loops


def _loops(kind, count=4):
    """``count`` loops of numbers at seeded log-uniform points of the example's box."""
    return example_loops(kind, count, seed=16)


def _rows(loop):
    """f, f′, f″ of |T/T(0)|² replayed on the loop's twin (fresh Functions: not kept)."""
    frequency._replays.clear()
    (rows, _) = frequency.replayed("test_steps", frequency_domain.normalised_gain_squared(loop), 2)
    return rows


def _windows(loop):
    """Whole windows of the loop's grid, as the peak's refinement starts them."""
    grid = np.log(frequency.log_grid(loop.frequency_band))
    h = (grid[1] - grid[0]) / 2
    return np.fmax(grid - 2 * h, grid[0]), np.fmin(grid + 2 * h, grid[-1]), grid


@pytest.mark.parametrize("kind", KINDS)
def test_folded_golden_steps_give_the_bits_of_the_float_steps(kind):
    for loop in _loops(kind):
        f, _, _ = _rows(loop)
        a, b, grid = _windows(loop)
        seen = f(grid)
        for steps in (frequency._SCREEN_STEPS, frequency._GOLDEN_STEPS):
            floats = frequency._golden_steps_of_numbers(f, steps, a, b, seen)  # first: floats
            for _ in range(frequency.DERIVED_AFTER - 1):  # floats until the build
                frequency._golden_steps_of_numbers(f, steps, a, b, seen)
            folded = frequency._golden_steps_of_numbers(f, steps, a, b, seen)  # then built
            assert isinstance(f._derived["golden", steps][1], frequency.Mapped)
            for x, y in zip(floats[:3], folded[:3]):
                assert np.array_equal(x, y)
            assert floats[3] is folded[3] is False


def test_folded_golden_steps_find_a_nan_as_the_float_steps_do():
    """√u is NaN left of 0: a window there stops the refinement either way (the peak then
    takes the symbolic path); ¬(f ≥ −∞) counts it, where CasADi folds f ≠ f to 0."""
    u = ca.MX.sym("u")
    f = frequency.Mapped(ca.Function("root", [u], [ca.sqrt(u)]))
    a, b = np.array([-1.0, 1.0]), np.array([0.5, 2.0])
    first = frequency._golden_steps_of_numbers(f, 6, a, b, np.zeros(2))
    second = frequency._golden_steps_of_numbers(f, 6, a, b, np.zeros(2))
    assert first[3] is True and second[3] is True
    positive = frequency._golden_steps_of_numbers(f, 6, a[1:], b[1:], np.zeros(1))
    assert positive[3] is False


@pytest.mark.parametrize("kind", KINDS)
def test_the_jet_gives_the_bits_of_f_and_its_derivatives(kind):
    for loop in _loops(kind):
        f, slope, curvature = _rows(loop)
        grid = np.log(frequency.log_grid(loop.frequency_band))
        points = np.concatenate([grid, (grid[1:] + grid[:-1]) / 2])
        separate = frequency._jet_columns(f, slope, curvature, points)  # first: three calls
        for _ in range(frequency.DERIVED_AFTER - 1):  # three calls until the build
            frequency._jet_columns(f, slope, curvature, points)
        jet = frequency._jet_columns(f, slope, curvature, points)  # then the CSE'd jet
        assert f._derived["jet",][1].fn.is_a("SXFunction")
        for x, y, g in zip(separate, jet, (f, slope, curvature)):
            assert np.array_equal(x, y, equal_nan=True)
            assert np.array_equal(x, g(points), equal_nan=True)


@pytest.mark.parametrize("kind", KINDS)
def test_folded_bisections_give_the_bits_of_the_float_steps(kind):
    for loop in _loops(kind):
        frequency._replays.clear()
        (f, _), _ = frequency.replayed(
            "test_bisection", frequency_domain.log_open_loop_gain_squared(loop), 1)
        grid = np.log(frequency.log_grid(loop.frequency_band))
        below = np.flatnonzero(f(grid)[1:] < 0)
        k = int(below[0]) + 1 if below.size else 1
        floats = frequency._bisections_of_numbers(f, float(grid[k - 1]), float(grid[k]))
        for _ in range(frequency.DERIVED_AFTER - 1):  # floats until the build
            frequency._bisections_of_numbers(f, float(grid[k - 1]), float(grid[k]))
        folded = frequency._bisections_of_numbers(f, float(grid[k - 1]), float(grid[k]))
        assert isinstance(f._derived["bisection", frequency._BISECTIONS][1], frequency.Mapped)
        assert floats == folded


def test_a_structures_third_peak_takes_a_few_calls(monkeypatch):
    """The point of it: the first loops of a structure refine in floats (≈ 100 calls of
    f, f′, f″; ``frequency.DERIVED_AFTER`` of them); from then on a peak is a few calls of
    Functions kept with its structure's, with the same result as the floats' steps on that
    loop."""
    frequency._replays.clear()
    *first, second = _loops("sampled", frequency.DERIVED_AFTER + 1)
    fn = frequency_domain.normalised_gain_squared
    for loop in first:  # floats; each asks once
        frequency.peak(fn(loop), loop.frequency_band, "test_calls")
    calls = []
    trigger = frequency.Buffered.__call__
    monkeypatch.setattr(frequency.Buffered, "__call__",
                        lambda self, *args: calls.append(1) or trigger(self, *args))
    folded = [float(ca.evalf(v)) for v in frequency.peak(fn(second), second.frequency_band,
                                                          "test_calls")]
    assert 0 < len(calls) <= 12, len(calls)
    monkeypatch.undo()
    frequency._replays.clear()  # the same loop again with fresh Functions: the floats' steps
    second.__dict__.pop("_parametric_twin", None)
    floats = [float(ca.evalf(v)) for v in frequency.peak(fn(second), second.frequency_band,
                                                          "test_calls")]
    assert folded == floats


def _without_replay(monkeypatch, evaluate):
    with monkeypatch.context() as patch:
        patch.setattr(frequency, "replayed_at", lambda *args: None)  # value_at's too
        patch.setattr("feedtune.objectives.frequency.gain_margin.replayed_at",
                      lambda *args: None)
        return evaluate()


@pytest.mark.parametrize("kind", KINDS)
def test_radial_error_and_margins_read_the_replayed_response_with_the_graphs_bits(
        kind, monkeypatch):
    metrics = [(RadialError(), CircleOptions(radius=0.005, feed=0.05)),
               (GainMargin(), GainMargin.Options()), (PhaseMargin(), PhaseMargin.Options())]
    for loop in _loops(kind):
        for metric, options in metrics:
            def evaluate(metric=metric, options=options):
                loop.__dict__.pop("_gain_crossover", None)
                value = metric.evaluate(loop, options)
                if isinstance(value, Unbounded):  # its value and whether it exists
                    return [float(ca.evalf(ca.MX(value.finite))),
                            float(ca.evalf(ca.MX(value.exists)))]
                expr, magnitude = exact_value(value)
                return [float(ca.evalf(ca.MX(ca.fabs(expr) if magnitude else expr)))]

            first = evaluate()  # a structure's first value: the graph (nothing built)
            replayed, built = evaluate(), _without_replay(monkeypatch, evaluate)
            assert np.array_equal(first, built, equal_nan=True)
            assert np.array_equal(replayed, built, equal_nan=True), (metric.name, replayed, built)
    replays = {key[0] for key, built in frequency._replays.items() if built}
    assert {"radius_gain_excess", "gain_margin", "gain_margin_real", "phase_margin"} <= replays


def test_replayed_at_takes_floats_of_loops_of_numbers_only():
    loop = _loops("sampled", 1)[0]
    fn = frequency_domain.normalised_gain_squared(loop)
    assert frequency.replayed_at("test_at", fn, 2.0) is None  # the first: not built
    assert frequency.replayed_at("test_at", fn, 2.0) is not None
    assert frequency.replayed_at("test_at", fn, ca.MX(2.0)) is None  # an expression
    assert frequency.replayed_at("test_at", lambda omega: omega, 2.0) is None  # no OfLoop
