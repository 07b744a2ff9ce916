"""Deterministic starting points of the multistart, in the logarithms of the tunables."""

from __future__ import annotations

import functools
import math

import numpy as np

from feedtune.tuner.types import Variable


def starting_points(variables: list[Variable], count: int) -> np.ndarray:
    """``count`` starts in ln(tunable): the initial point (the box's geometric middle for a
    tunable without one), then an unscrambled Halton sequence over the box (its first
    point, the box's corner, skipped). Shape (count, len(variables))."""
    if not variables:
        return np.zeros((1, 0))
    lower = np.log([v.lower for v in variables])
    upper = np.log([v.upper for v in variables])
    first = np.array([math.log(v.initial) if v.initial else (lo + hi) / 2
                      for v, lo, hi in zip(variables, lower, upper)])
    points = [first]
    if count > 1:
        points.extend(lower + _halton(len(variables), count) * (upper - lower))
    return np.array(points[:count])


@functools.lru_cache(maxsize=64)
def _halton(dimension: int, count: int) -> np.ndarray:
    """The unscrambled Halton points 2 … ``count`` in [0, 1)^``dimension`` (read-only),
    once per process: scipy's sequence object costs ≈ 0.5–1 ms to set up (its primes and
    permutation tables), as much as a batch spec's restoration checks, and the points are
    the same for every spec of a dimension."""
    from scipy.stats import qmc  # 0.2 s of imports: only when a second start is wanted

    unit = qmc.Halton(dimension, scramble=False).random(count)[1:]
    unit.flags.writeable = False
    return unit
