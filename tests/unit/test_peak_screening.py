"""Issue 15: the final evaluation of a loop of numbers is faster, with the same bits.

- :func:`feedtune.loops.frequency._peak_of_numbers` refines to the end only the windows whose
  bound after a few golden steps reaches the largest grid value: the answer must be the
  one of refining every window, to the last bit (the screen switched off by setting
  ``_SCREEN_STEPS`` to the number of golden steps);
- :func:`feedtune.loops.frequency._number_functions` builds f, f′, f″ in SX directly: the same
  bits as expanding the MX Functions the symbolic path builds, and None on a loop of
  symbols (which keeps the symbolic path);
- the gain and phase margins read L at a crossing of numbers in floats: the same bits as
  evaluating the graph at that crossing.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

import feedtune.loops.frequency as frequency
from feedtune.objectives import METRICS
from feedtune.objectives.frequency import frequency_domain
from feedtune.problem import build_plant, resolve_tunables
from feedtune.schema.spec import parse_spec
from feedtune.tuner.terms import exact_value

REPO = Path(__file__).resolve().parents[2]
EXAMPLES = ["koren-1979-sampled-data", "bhatia-1971-hydraulic", "ward-leonard-feed-drive"]


def _loops(example, count):
    """The plant, and its loops at the stored tuned design (where there is one) and at
    ``count`` log-uniform points of the box (seed 15)."""
    spec = parse_spec((REPO / "examples" / f"{example}.json").read_text())
    plant = build_plant(spec)
    _, _, box = resolve_tunables(spec, plant)
    stored = REPO / "tests" / "data" / f"{example}.result.json"
    points = []
    if stored.exists():
        points.append({n: t["value"] for n, t in json.loads(stored.read_text())["tuned"].items()})
    rng = np.random.default_rng(15)
    points += [{n: math.exp(rng.uniform(math.log(lo), math.log(hi))) for n, (lo, hi) in box.items()}
               for _ in range(count)]
    return [plant.loop(values, box) for values in points]


def _sensitivity_squared(loop):
    def gain(omega):
        re, im = loop.error_response(omega)
        return re**2 + im**2

    return gain


def _responses(loop):
    """The functions the peaks and crossings of the reports are located on."""
    return {"|T|^2": frequency_domain.normalised_gain_squared(loop),
            "|S|^2": _sensitivity_squared(loop),
            "ln|L|^2": frequency_domain.log_open_loop_gain_squared(loop),
            "-Im L/|L|": frequency_domain.phase_crossover_indicator(loop)}


def _peak_both_ways(fn, band, monkeypatch):
    """``_peak_of_numbers`` screened, and with every window refined to the end."""
    functions = frequency._number_functions("f", fn, 2)
    if functions is None:  # a response built on MX matrices: the expanded MX Functions
        functions, free = frequency._functions("f", fn, 2)
        assert not free
    grid = np.log(frequency.log_grid(band))
    h = (grid[1] - grid[0]) / 2
    functions = [frequency.Mapped(fn) for fn in functions]
    screened = frequency._peak_of_numbers(*functions, grid, h)
    with monkeypatch.context() as patch:
        patch.setattr(frequency, "_SCREEN_STEPS", frequency._GOLDEN_STEPS)
        every = frequency._peak_of_numbers(*functions, grid, h)
    return screened, every


@pytest.mark.parametrize("example", EXAMPLES)
def test_screening_gives_the_bits_of_refining_every_window(example, monkeypatch):
    for loop in _loops(example, 6):
        for name in ("|T|^2", "|S|^2"):
            screened, every = _peak_both_ways(_responses(loop)[name], loop.frequency_band,
                                              monkeypatch)
            assert screened == every or (
                screened is not None and every is not None
                and np.array_equal(screened, every, equal_nan=True)), (name, every, screened)


@pytest.mark.parametrize("zeta", [0.02, 0.015, 0.01])
def test_screening_keeps_a_light_resonance_between_grid_points(zeta, monkeypatch):
    """A broad peak (ζ = 0.3 at 0.9 rad/s, height 305) and a light one at ω₀ ≈ 307 rad/s
    midway between grid points 179 and 180 (40 a decade from 0.01 rad/s), height
    ½/(2ζ)² ≥ 312 that wins, though its grid values stay below the broad peak's: only the
    bound on what the refinement can still reach keeps its windows."""
    w0 = 0.01 * 10 ** (179.5 / frequency.POINTS_PER_DECADE)

    def gain(omega):
        first = 1 / ((1 - omega**2) ** 2 + (0.6 * omega) ** 2)
        second = w0**4 / ((w0**2 - omega**2) ** 2 + (2 * zeta * w0 * omega) ** 2)
        return 100 * first + 0.5 * second

    grid = frequency.log_grid((1e-2, 1e4))
    assert grid[np.argmax(gain(grid))] < 10  # the broad peak tops the grid
    screened, every = _peak_both_ways(gain, (1e-2, 1e4), monkeypatch)
    assert screened == every
    assert math.exp(screened[1]) == pytest.approx(w0 * math.sqrt(1 - 2 * zeta**2), rel=1e-6)


def test_the_screen_drops_most_windows(monkeypatch):
    """The point of it: on Bhatia's tuned |T|², far fewer than all windows go on, both to
    the screening golden steps (the bound on whole windows) and to the end (the bound
    after them)."""
    loop = _loops("bhatia-1971-hydraulic", 0)[0]
    kept = []
    bound = frequency._bound  # both screens' bound (the whole windows' read on the grid)

    def counting(f_m, slope_m, curvature_m, r, seen):
        values = bound(f_m, slope_m, curvature_m, r, seen)
        kept.append((int(np.count_nonzero(values >= seen.max())), r.size))
        return values

    monkeypatch.setattr(frequency, "_bound", counting)
    frequency.peak(frequency_domain.normalised_gain_squared(loop), loop.frequency_band)
    (passed, windows), (refined, screened) = kept  # whole windows, then narrowed brackets
    assert passed <= screened <= 3 * passed and screened <= windows // 10, kept  # neighbours too
    assert refined <= screened, kept


@pytest.mark.parametrize("example", EXAMPLES)
def test_sx_functions_are_the_expanded_mx_functions(example):
    """f, f′ and f″ on the grid and between its points: the same bits, or both NaN."""
    for loop in _loops(example, 4):
        grid = np.log(frequency.log_grid(loop.frequency_band))
        points = np.concatenate([grid, (grid[1:] + grid[:-1]) / 2])
        for name, fn in _responses(loop).items():
            built = frequency._number_functions("f", fn, 2)
            if built is None:
                assert example.startswith("koren") and name == "|S|^2"  # MX matrices
                continue
            expanded, free = frequency._functions("f", fn, 2)
            assert not free
            for sx, mx in zip(built, expanded):
                new = np.asarray(sx.map(points.size)(points[None, :])).ravel()
                old = np.asarray(mx.expand().map(points.size)(points[None, :])).ravel()
                assert np.array_equal(new, old, equal_nan=True), name


def test_a_loop_of_symbols_keeps_the_symbolic_path():
    x = ca.MX.sym("x")
    assert frequency._number_functions("f", lambda w: x / (1 + w**2), 2) is None


@pytest.mark.parametrize("example", EXAMPLES)
@pytest.mark.parametrize("metric", ["gain_margin", "phase_margin"])
def test_margins_read_the_crossing_in_floats_with_the_same_bits(example, metric, monkeypatch):
    def value(loop):
        expr, _ = exact_value(METRICS[metric]().evaluate(loop, METRICS[metric].Options()))
        return float(ca.evalf(ca.MX(expr)))

    for loop in _loops(example, 3):
        new = value(loop)
        with monkeypatch.context() as patch:
            patch.setattr(frequency_domain, "as_number", lambda omega: omega)
            loop.__dict__.pop("_gain_crossover", None)
            old = value(loop)
        assert new == old or (math.isnan(new) and math.isnan(old))


@pytest.mark.parametrize("example", EXAMPLES)
def test_a_loop_builds_each_response_once_at_the_shared_omega(example):
    """Peaks and crossings build on one ln ω symbol per kind, and a loop keeps its responses
    there (feedtune.loops.loop.at_shared_omega): M_peak and the bandwidth read one |T|, the
    margins and the crossover one L. Any other ω builds anew; the peak of a loop that built
    its responses for other reports first has the bits of a fresh loop's."""
    shared, fresh = _loops(example, 1)[-1], _loops(example, 1)[-1]
    _, omega = frequency._log_omega("MX")
    assert shared.frequency_response(omega) is shared.frequency_response(omega)
    assert shared.open_loop_response(omega) is shared.open_loop_response(omega)
    assert shared.frequency_response(2.0) is not shared.frequency_response(2.0)
    for fn in (frequency_domain.log_open_loop_gain_squared, frequency_domain.normalised_gain_squared):
        frequency.first_crossing(fn(shared), shared.frequency_band, 0.5)
    band = shared.frequency_band
    again = frequency.peak(frequency_domain.normalised_gain_squared(shared), band)
    alone = frequency.peak(frequency_domain.normalised_gain_squared(fresh), band)
    assert [float(ca.evalf(v)) for v in again] == [float(ca.evalf(v)) for v in alone]
