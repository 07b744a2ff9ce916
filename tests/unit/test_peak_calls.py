"""A structure's peaks and crossings in fewer steps and calls (issue 15, branch h-bev6).

- 20 golden-section steps a window instead of 48, in every path: the bracket is then
  7.6e-6 wide in ln ω and the two Newton steps finish; the peak's value must stay within
  1e-9 of its value (a magnitude ≈ 1) of the 48 steps' on Koren's loops at seeded points
  of their boxes, stable or not, and on a light resonance between grid points;
- from a structure's second loop on, a peak's grid values and whole-window screen come
  from one call of the jet on the grid, its last golden steps, Newton steps and value
  from one Function, a crossing's bisections and Newton steps from one Function: the
  float steps' bits, in a few calls;
- the relative grid of a band is computed once and read-only.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import feedtune.loops.frequency as frequency
from feedtune.objectives.frequency import frequency_domain
from feedtune.objectives.frequency.sensitivity_peak import sensitivity_squared
from feedtune.loops.twin import OfLoop
from example_loops import KINDS, example_loops


def _loops(kind, count=4):
    """``count`` loops of numbers at seeded log-uniform points of the example's box."""
    return example_loops(kind, count, seed=61)


def _peaks(kind):
    """(f, f′, f″ rows, ln ω grid, half step) of |T/T(0)|² and |S|² of each loop, replayed."""
    for loop in _loops(kind):
        grid = np.log(frequency.log_grid(loop.frequency_band))
        h = float(grid[1] - grid[0]) / 2
        for name, fn in (("test_calls_t", frequency_domain.normalised_gain_squared(loop)),
                         ("test_calls_s", OfLoop(sensitivity_squared, loop))):
            rows, _ = frequency.replayed(name, fn, 2)
            yield rows, grid, h


@pytest.mark.parametrize("kind", KINDS)
def test_twenty_golden_steps_give_the_peak_of_forty_eight(kind, monkeypatch):
    for rows, grid, h in _peaks(kind):
        fewer = frequency._peak_of_numbers(*rows, grid, h)
        with monkeypatch.context() as patch:
            patch.setattr(frequency, "_GOLDEN_STEPS", 48)
            more = frequency._peak_of_numbers(*rows, grid, h)
        assert (fewer is None) == (more is None)
        if fewer is not None:
            assert abs(fewer[0] - more[0]) <= 1e-9 * abs(more[0]), (fewer, more)


@pytest.mark.parametrize("zeta", [0.02, 0.005, 0.002])
def test_twenty_golden_steps_locate_a_light_resonance(zeta, monkeypatch):
    """A light resonance between grid points (ω₀ midway between two of 40 a decade): its
    top ½/(2ζ√(1 − ζ²))² and where it is, √(1 − 2ζ²)·ω₀, to 1e-9 relative."""
    w0 = 0.01 * 10 ** (179.5 / frequency.POINTS_PER_DECADE)

    def gain(omega):
        return 0.5 * w0**4 / ((w0**2 - omega**2) ** 2 + (2 * zeta * w0 * omega) ** 2)

    top, omega = (float(v) for v in frequency.peak(gain, (1e-2, 1e4)))
    assert top == pytest.approx(0.5 / (4 * zeta**2 * (1 - zeta**2)), rel=1e-9)
    assert omega == pytest.approx(w0 * math.sqrt(1 - 2 * zeta**2), rel=1e-9)


def _counting(monkeypatch):
    calls = []
    trigger = frequency.Buffered.__call__
    monkeypatch.setattr(frequency.Buffered, "__call__",
                        lambda self, *args: calls.append(self._fn.name()) or trigger(self, *args))
    return calls


@pytest.mark.parametrize("kind", KINDS)
def test_a_structures_peak_is_four_calls_with_the_float_steps_bits(kind, monkeypatch):
    for rows, grid, h in _peaks(kind):
        frequency._peak_of_numbers(*rows, grid, h)  # builds the jet and the folds
        frequency._peak_of_numbers(*rows, grid, h)
        with monkeypatch.context() as patch:
            calls = _counting(patch)
            folded = frequency._peak_of_numbers(*rows, grid, h)
        assert len(calls) <= 4 and not any(name.endswith("_0") for name in calls), calls
        floats = [frequency.Mapped(row.fn, expand=False).bound(*row.fixed) for row in rows]
        assert folded == frequency._peak_of_numbers(*floats, grid, h)  # fresh: float steps


@pytest.mark.parametrize("kind", KINDS)
def test_a_structures_crossing_is_one_call_with_the_float_steps_bits(kind, monkeypatch):
    for loop in _loops(kind):
        for fn in (frequency_domain.log_open_loop_gain_squared(loop),
                   frequency_domain.phase_crossover_indicator(loop)):
            (f, slope), _ = frequency.replayed("test_calls_x", fn, 1)
            grid = np.log(frequency.log_grid(loop.frequency_band))
            values = f(grid)
            for _ in range(frequency.DERIVED_AFTER):  # floats; the next request builds it
                frequency._first_crossing_of_numbers(f, slope, grid, values)
            with monkeypatch.context() as patch:
                calls = _counting(patch)
                folded = frequency._first_crossing_of_numbers(f, slope, grid, values)
            assert len(calls) <= 1, calls
            floats = [frequency.Mapped(row.fn, expand=False).bound(*row.fixed)
                      for row in (f, slope)]
            assert folded == frequency._first_crossing_of_numbers(*floats, grid, values)


def test_a_bands_relative_grid_is_computed_once_and_read_only(monkeypatch):
    band = (0.321, 6.54e4)
    expected = np.geomspace(band[0] / band[1], 1.0, frequency._relative_points(band[1] / band[0]))
    first = frequency.relative_grid(band)
    assert np.array_equal(first, expected[:-1]) and not first.flags.writeable
    monkeypatch.setattr(np, "geomspace", lambda *args, **kwargs: pytest.fail("computed again"))
    assert frequency.relative_grid(band) is first
