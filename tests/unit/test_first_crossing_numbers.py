"""feedtune.loops.frequency.first_crossing on a loop of numbers takes a float path (no graph of
if_else nodes is built); it must give what the symbolic path gives, to the last bit."""

import math

import casadi as ca
import pytest

from feedtune.loops.frequency import first_crossing

BAND = (1e-2, 1e4)  # rad/s


def _gain(k):
    """|T|² of k/(s(s + 1) + k) [1], with a resonance for k > 1/2."""
    def gain(omega):
        re, im = k - omega**2, omega
        return k**2 / (re**2 + im**2)

    return gain


@pytest.mark.parametrize("k", [0.3, 2.0, 50.0, 1e6])
def test_numbers_give_the_symbolic_answer(k):
    x = ca.MX.sym("x")
    symbolic = first_crossing(lambda w: _gain(k + 0 * x)(w), BAND, 0.5)
    expected = float(ca.Function("f", [x], [symbolic])(0.0))
    assert float(ca.evalf(first_crossing(_gain(k), BAND, 0.5))) == expected


def test_no_crossing_in_the_band_is_its_top():
    assert float(ca.evalf(first_crossing(lambda w: 1 + 0 * w, BAND, 0.5))) == pytest.approx(
        BAND[1], rel=1e-12)


def test_the_crossing_is_the_half_power_point():
    """The overdamped loop k = 0.3: |T|² = 1/2 found by plain bisection in floats."""
    gain = _gain(0.3)
    lo, hi = 1e-2, 1e4
    for _ in range(200):
        mid = math.sqrt(lo * hi)
        lo, hi = (mid, hi) if gain(mid) > 0.5 else (lo, mid)
    assert float(ca.evalf(first_crossing(gain, BAND, 0.5))) == pytest.approx(lo, rel=1e-12)


@pytest.mark.parametrize("example", ["bhatia-1971-hydraulic", "ward-leonard-feed-drive"])
def test_bundled_loops_give_the_symbolic_answer(example):
    """The crossings the reports take (bandwidth, gain crossover, phase crossover) at the
    stored tuned design and 6 log-uniform points of the box (seed 15), f and f′ SX-expanded
    on the float path: the same bits as the symbolic path (the response times a symbol
    x = 1), or both NaN."""
    import json
    from pathlib import Path

    import numpy as np

    from feedtune.objectives.frequency import frequency_domain
    from feedtune.problem import build_plant, resolve_tunables
    from feedtune.schema.spec import parse_spec

    repo = Path(__file__).resolve().parents[2]
    spec = parse_spec((repo / "examples" / f"{example}.json").read_text())
    plant = build_plant(spec)
    _, _, box = resolve_tunables(spec, plant)
    tuned = json.loads((repo / "tests" / "data" / f"{example}.result.json").read_text())["tuned"]
    rng = np.random.default_rng(15)
    points = [{name: t["value"] for name, t in tuned.items()}] + [
        {name: math.exp(rng.uniform(math.log(lo), math.log(hi))) for name, (lo, hi) in box.items()}
        for _ in range(6)]
    x = ca.MX.sym("x")
    for values in points:
        loop = plant.loop(values, box)
        for fn, level in ((frequency_domain.normalised_gain_squared(loop), 0.5),
                          (frequency_domain.log_open_loop_gain_squared(loop), 0.0),
                          (frequency_domain.phase_crossover_indicator(loop), 0.0)):
            numbers = float(ca.evalf(first_crossing(fn, loop.frequency_band, level)))
            symbolic = first_crossing(lambda w, fn=fn: fn(w) * x, loop.frequency_band, level)
            expected = float(ca.Function("f", [x], [symbolic])(1.0))
            assert numbers == expected or (math.isnan(numbers) and math.isnan(expected)), values
