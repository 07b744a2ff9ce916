"""Deterministic starting points of the multistart, in the logarithms of the tunables."""

from __future__ import annotations

import functools
import math

import numpy as np

from feedtune.tuner.types import Variable

#: a Halton point within this fraction of the box's width [ln] of the first start, in every
#: tunable, is that start (the box's middle computed two ways differs in the last bits)
SAME_POINT = 1e-9


def starting_points(variables: list[Variable], count: int) -> np.ndarray:
    """``count`` starts in ln(tunable): the initial point (the box's geometric middle for a
    tunable without one), then an unscrambled Halton sequence over the box (its first
    point, the box's corner, skipped, and so is a point at the first start). Shape
    (count, len(variables))."""
    if not variables:
        return np.zeros((1, 0))
    lower = np.log([v.lower for v in variables]).tolist()
    upper = np.log([v.upper for v in variables]).tolist()
    width = [hi - lo for lo, hi in zip(lower, upper)]
    first = [math.log(v.initial) if v.initial else (lo + hi) / 2
             for v, lo, hi in zip(variables, lower, upper)]
    points = [first]
    if count > 1:
        # one point more than needed: a Halton point at the first start (in one dimension
        # the sequence's first point after the corner, 1/2, is the box's middle) is skipped,
        # as a start repeated is no further evidence of where the optimum lies; in floats,
        # lower + unit·(upper − lower) rounded as numpy's arrays round it
        for unit in _halton(len(variables), count + 1).tolist():
            point = [lo + u * w for lo, u, w in zip(lower, unit, width)]
            if not all(abs(x - f) <= SAME_POINT * w for x, f, w in zip(point, first, width)):
                points.append(point)
    return np.array(points[:count])


@functools.lru_cache(maxsize=64)
def _halton(dimension: int, count: int) -> np.ndarray:
    """The unscrambled Halton points 2 … ``count`` in [0, 1)^``dimension`` (read-only),
    once per process: coordinate j of point i is the radical inverse of i in the j-th prime
    base (van der Corput), summed digit by digit as scipy's ``qmc.Halton(d,
    scramble=False)`` sums it, so the points are scipy's to the bit
    (tests/unit/test_tuner_starts.py). Written here rather than taken from scipy because
    ``scipy.stats`` costs 0.2–0.5 s of imports in every process that tunes (issue 15)."""
    unit = np.empty((count - 1, dimension))
    for column, base in enumerate(_primes(dimension)):
        for row, index in enumerate(range(1, count)):
            value, scale = 0.0, 1.0 / base
            while index > 0:
                index, digit = divmod(index, base)
                value += digit * scale
                scale /= base
            unit[row, column] = value
    unit.flags.writeable = False
    return unit


def _primes(count: int) -> list[int]:
    """The first ``count`` primes, the Halton sequence's bases."""
    primes: list[int] = []
    candidate = 2
    while len(primes) < count:
        if all(candidate % p for p in primes):
            primes.append(candidate)
        candidate += 1
    return primes
