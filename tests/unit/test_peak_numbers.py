"""feedtune.loops.frequency.peak on a loop of numbers takes a float path (issue 15: no graph of
48 golden-section steps over the grid is built; f, f′, f″ SX-expanded): it must give what
the symbolic path gives, to the last bit, for toy responses, the bundled Bhatia and
Ward-Leonard loops (tuned and hand designs), seeded random points of their boxes, and
M_peak as the metric reports it. The symbolic path is the same function with the float
path switched off."""

from __future__ import annotations

import json
import math
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

import feedtune.loops.frequency as frequency
from feedtune.objectives.frequency.frequency_domain import normalised_gain_squared
from feedtune.objectives.frequency.m_peak import MPeak
from feedtune.problem import build_plant, resolve_tunables
from feedtune.schema.spec import parse_spec
from feedtune.tuner.terms import exact_value

REPO = Path(__file__).resolve().parents[2]
BAND = (1e-2, 1e4)  # rad/s


def _both(fn, band, monkeypatch):
    """(value, ω) of peak() by the float path, and by the symbolic path, as floats."""
    new = [float(ca.evalf(x)) for x in frequency.peak(fn, band)]
    with monkeypatch.context() as patch:
        patch.setattr(frequency, "_peak_of_numbers", lambda *args: None)
        old = [float(ca.evalf(x)) for x in frequency.peak(fn, band)]
    return new, old


def _gain(k):
    """|T|² of k/(s(s + 1) + k) [1], with a resonance for k > 1/2."""
    def gain(omega):
        re, im = k - omega**2, omega
        return k**2 / (re**2 + im**2)

    return gain


@pytest.mark.parametrize("k", [0.3, 0.6, 2.0, 50.0, 1e6])
def test_second_order_loops(k, monkeypatch):
    new, old = _both(_gain(k), BAND, monkeypatch)
    assert new == old


def test_two_resonances_the_lighter_one_wins(monkeypatch):
    """The sum of two second-order |T|² at 1 and 300 rad/s, ζ = 0.3 (peak ≈ 3) and 0.05
    (peak ≈ 100, at 300·√(1 − 2ζ²))."""
    def gain(omega):
        first = 1 / ((1 - omega**2) ** 2 + (0.6 * omega) ** 2)
        second = 300**4 / ((300**2 - omega**2) ** 2 + (30 * omega) ** 2)
        return first + second

    new, old = _both(gain, BAND, monkeypatch)
    assert new == old and new[1] == pytest.approx(300 * math.sqrt(1 - 2 * 0.05**2), rel=1e-6)


@pytest.mark.parametrize("fn", [lambda w: 1 / (1 + w**2), lambda w: 1 + 0 * w,
                                lambda w: w**2 / (1 + w**2)], ids=["lowpass", "flat", "highpass"])
def test_no_interior_peak(fn, monkeypatch):
    """Largest at ω = 0 (ω reported 0), flat (ties), largest at the top of the band."""
    new, old = _both(fn, BAND, monkeypatch)
    assert new == old


def _plant_box(example):
    spec = parse_spec((REPO / "examples" / f"{example}.json").read_text())
    plant = build_plant(spec)
    _, _, box = resolve_tunables(spec, plant)
    return spec, plant, box


def _tuned(example):
    data = json.loads((REPO / "tests" / "data" / f"{example}.result.json").read_text())
    return {name: t["value"] for name, t in data["tuned"].items()}


EXAMPLES = ["bhatia-1971-hydraulic", "ward-leonard-feed-drive"]


@pytest.mark.parametrize("example", EXAMPLES)
@pytest.mark.parametrize("point", ["tuned", "initial"])
def test_bundled_loops(example, point, monkeypatch):
    spec, plant, box = _plant_box(example)
    values = _tuned(example) if point == "tuned" else {
        name: (spec.tunables[name].initial if name in spec.tunables
               and spec.tunables[name].initial is not None else math.sqrt(lo * hi))
        for name, (lo, hi) in box.items()}
    loop = plant.loop(values, box)
    new, old = _both(normalised_gain_squared(loop), loop.frequency_band, monkeypatch)
    assert new == old


@pytest.mark.parametrize("example", EXAMPLES)
def test_random_points_of_the_box(example, monkeypatch):
    """Eight log-uniform points (seed 15), stable or not: the same bits or both NaN."""
    _, plant, box = _plant_box(example)
    rng = np.random.default_rng(15)
    for _ in range(8):
        values = {name: math.exp(rng.uniform(math.log(lo), math.log(hi)))
                  for name, (lo, hi) in box.items()}
        loop = plant.loop(values, box)
        new, old = _both(normalised_gain_squared(loop), loop.frequency_band, monkeypatch)
        assert np.array_equal(new, old, equal_nan=True), values


@pytest.mark.parametrize("example", EXAMPLES)
def test_m_peak_as_reported(example, monkeypatch):
    """The metric's exact value (the number a result reports) and its located ω."""
    _, plant, box = _plant_box(example)

    def evaluate():
        supremum = MPeak().evaluate(plant.loop(_tuned(example), box), MPeak.Options())
        expr, _ = exact_value(supremum)
        return float(ca.evalf(expr))

    new = evaluate()
    monkeypatch.setattr(frequency, "_peak_of_numbers", lambda *args: None)
    assert new == evaluate() and new == pytest.approx(1.3, abs=1e-6)
