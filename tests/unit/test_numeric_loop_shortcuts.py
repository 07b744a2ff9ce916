"""Shortcuts a loop of numbers takes when a batch evaluates a tuned design (issue 15): each
must give the bits the expression path gives, on Koren's sampled-data and reference-pulse
loops at seeded points of their boxes.

- step integrals summed by folds of 2^k samples (``loop._binary_chunks``) instead of one
  fold of the whole horizon;
- stability conditions from the characteristic polynomial's numbers and the Hurwitz
  Function evaluated on them (``linalg.hurwitz_conditions_of_numbers``);
- the minimum radius's refinements through CasADi's evaluation buffer (``Mapped``);
- one sampled step response for overshoot and settling time;
- the validator's closed loop and poles once per model, handed out as copies.
"""

from __future__ import annotations

import math
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

import feedtune.loops.loop as loop_module
import feedtune.objectives.contour.min_radius as min_radius
from feedtune.expr import to_float
from feedtune.loops import linalg
from feedtune.loops.frequency import Mapped
from feedtune.loops.timeresponse import sampled_step_error
from feedtune.objectives import METRICS
from feedtune.problem import build_plant, resolve_tunables
from feedtune.schema.spec import parse_spec
from feedtune.validate.software_servo import ServoModel

REPO = Path(__file__).resolve().parents[2]
EXAMPLES = ["koren-1979-sampled-data", "koren-1979-reference-pulse"]


def _loops(example: str, count: int = 5):
    """Loops of numbers at ``count`` log-uniform points of the example's box (seed 15)."""
    spec = parse_spec((REPO / "examples" / f"{example}.json").read_text())
    plant = build_plant(spec)
    _, _, box = resolve_tunables(spec, plant)
    rng = np.random.default_rng(15)
    points = [{n: math.exp(rng.uniform(math.log(lo), math.log(hi))) if lo < hi else lo
               for n, (lo, hi) in box.items()} for _ in range(count)]
    return [(plant, box, values) for values in points]


def test_binary_chunks_are_the_powers_of_two_of_the_count():
    assert loop_module._binary_chunks(13) == [8, 4, 1]
    assert loop_module._binary_chunks(1) == [1]
    assert loop_module._binary_chunks(4096) == [4096]
    for samples in (7, 100, 1234, 65535):
        chunks = loop_module._binary_chunks(samples)
        assert sum(chunks) == samples
        assert all(c & (c - 1) == 0 for c in chunks) and chunks == sorted(chunks, reverse=True)


@pytest.mark.parametrize("name", ["iae", "ise", "itae"])
def test_step_integrals_by_chunks_are_one_fold_bit_for_bit(name):
    for plant, box, values in _loops("koren-1979-sampled-data"):
        loop = plant.loop(values, box)
        chunked = float(getattr(loop.step_error_integrals, name))
        # the same sum as one fold of the whole horizon, as the NLP's graph has it
        n, samples = loop.order, loop.horizon_samples
        phi, gamma, kx, kr = (ca.evalf(ca.MX(m)) for m in loop._matrices)
        period, tau = (ca.evalf(ca.MX(v)) for v in (loop.period, loop.plant.time_constant))
        final = loop_module._sample_fold(n, name, samples)(ca.DM.zeros(n + 2), phi, gamma, kx,
                                                            kr, period, tau)
        tail = loop_module._tail(n, name)(final[:n], final[n + 1], phi, gamma, kx, period, tau)
        whole = float(final[n] + (tail if name == "ise" else ca.fabs(tail)))
        assert chunked == whole, (values, chunked, whole)


def test_a_loop_of_numbers_builds_folds_of_powers_of_two_only(monkeypatch):
    """Horizons vary with every loop's spectral radius; folds of 2^k samples keep the
    builds to ≈ 20 sizes per structure instead of one per horizon."""
    sizes = []
    original = loop_module._sample_fold

    def spy(order, name, samples):
        sizes.append(samples)
        return original(order, name, samples)

    monkeypatch.setattr(loop_module, "_sample_fold", spy)
    horizons = set()
    for plant, box, values in _loops("koren-1979-sampled-data", 8):
        loop = plant.loop(values, box)
        float(loop.step_error_integrals.iae)
        horizons.add(loop.horizon_samples)
    assert any(h & (h - 1) for h in horizons), horizons  # some horizon is not a power of 2
    assert sizes and all(s & (s - 1) == 0 for s in sizes), sizes


@pytest.mark.parametrize("example", EXAMPLES)
def test_stability_conditions_of_numbers_are_the_expressions_evaluated(example):
    for plant, box, values in _loops(example, 8):
        loop = plant.loop(values, box)
        poly = loop.characteristic_polynomial
        if loop.discrete:
            poly = linalg.bilinear_to_continuous(poly)
        expected = [to_float(c) for c in linalg.hurwitz_conditions(poly)]
        got = [to_float(c) for c in plant.loop(values, box).stability_conditions()]
        assert got == expected, values


def test_stability_conditions_of_symbols_stay_expressions():
    plant, box, values = _loops("koren-1979-sampled-data", 1)[0]
    gain = ca.MX.sym("K")
    conditions = plant.loop({**values, "position_gain": gain}, box).stability_conditions()
    assert conditions and all(isinstance(c, ca.MX) and ca.depends_on(c, gain) for c in conditions)


@pytest.mark.parametrize("example", EXAMPLES)
def test_min_radius_refinements_through_the_buffer_give_the_dm_calls_bits(example, monkeypatch):
    metric = METRICS["min_radius"]()
    for plant, box, values in _loops(example, 4):
        loop = plant.loop(values, box)
        fast = float(ca.evalf(metric.evaluate(loop, None)))

        def dm_calls(fn):  # the evaluation before: a map per size, called with a DM
            # (replayed on the loop's twin, fn is a Mapped: its Function and its numbers)
            fn, fixed = (fn.fn, fn.fixed) if isinstance(fn, Mapped) else (fn, ())
            shared = [False] + [True] * (fn.n_in() - 1)
            maps = {}

            def evaluate(u):
                size = np.size(u)
                if size not in maps:
                    maps[size] = fn if size == 1 else fn.map(size, shared, [False])
                return np.array(maps[size](np.reshape(u, (1, size)), *fixed),
                                dtype=float).ravel()

            return evaluate

        with monkeypatch.context() as patch:
            patch.setattr(min_radius, "_vectorised", dm_calls)
            slow = float(ca.evalf(metric.evaluate(plant.loop(values, box), None)))
        assert fast == slow or (math.isnan(fast) and math.isnan(slow)), (values, fast, slow)


def test_overshoot_and_settling_share_one_step_response():
    plant, box, values = _loops("koren-1979-sampled-data", 1)[0]
    loop = plant.loop(values, box)
    first = sampled_step_error(loop)
    assert first is not None and sampled_step_error(loop) is first
    assert sampled_step_error(plant.loop(values, box)) is not first  # another loop: its own


def test_validator_closed_loop_and_poles_are_copies_of_one_computation():
    model = ServoModel(20.0, 0.02, 1 / 64, 1, blu=5e-6, max_velocity=0.04)
    f, g = model.closed_loop()
    poles = model.poles()
    f[:] = 0.0
    g[:] = 0.0
    poles[:] = 0.0
    again_f, again_g = model.closed_loop()
    assert np.any(again_f != 0) and np.any(again_g != 0) and np.any(model.poles() != 0)
    assert np.array_equal(model.poles(), np.linalg.eigvals(again_f))
