"""A tuned design's reports computed once where several read the same numbers (issue 15,
branch h-bev5).

Each change must leave every reported number's bits as they were (the batch's 300 result
files are compared field by field in ``benchmarks/batch_throughput.py``); here on Koren's
loops at seeded points of their box, against what the previous code computed.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

import feedtune.loops.frequency as frequency
import feedtune.loops.loop as loop_module
from example_loops import example_loops


def _bits(values) -> list[str]:
    """Each number's hex form: equal bits, signed zeros told apart."""
    return [float(v).hex() for v in np.asarray(values, dtype=float).ravel()]


def _one_integral(loop, name: str):
    """The step integral ``name`` summed alone, by its own folds (as before h-bev5)."""
    n = loop.order
    phi, gamma, kx, kr, period, tau = (ca.evalf(ca.MX(m)) for m in (
        *loop._matrices, loop.period, loop.plant.time_constant))
    final = ca.DM.zeros(n + 2)
    for k in loop_module._binary_chunks(loop.horizon_samples):
        final = loop_module._sample_fold(n, name, k)(final, phi, gamma, kx, kr, period, tau)
    tail = loop_module._tail(n, name)(final[:n], final[n + 1], phi, gamma, kx, period, tau)
    return final[n] + (tail if name == "ise" else ca.fabs(tail))


def _stable_sampled_loops(count: int, seed: int) -> list:
    """Sampled Koren loops of numbers at seeded points of the box, the stable ones (an
    unstable loop's integrals are +∞ without a sum)."""
    return [loop for loop in example_loops("sampled", count, seed=seed)
            if loop._numeric_spectral_radius < 1]


def test_a_sampled_loop_of_numbers_sums_its_three_step_integrals_in_one_pass(monkeypatch):
    loops = _stable_sampled_loops(6, seed=41)
    assert len(loops) >= 3
    expected = [[_one_integral(loop, name) for name in ("iae", "ise", "itae")]
                for loop in loops]
    calls = []
    original = frequency.Buffered.__call__

    def spy(self, *args):
        calls.append(self._fn.name())
        return original(self, *args)

    monkeypatch.setattr(frequency.Buffered, "__call__", spy)
    for loop, values in zip(_stable_sampled_loops(6, seed=41), expected):
        calls.clear()
        integrals = loop.step_error_integrals
        got = [integrals.iae, integrals.ise, integrals.itae]
        assert _bits(got) == _bits(values)
        chunks = loop_module._binary_chunks(loop.horizon_samples)
        # main: one fold a chunk and one tail for each integral (3 × (chunks + 1) calls)
        assert len(calls) == len(chunks) + 1, calls
