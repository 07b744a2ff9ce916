"""Deterministic starting points of the multistart, in the logarithms of the tunables."""

from __future__ import annotations

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
        from scipy.stats import qmc  # 0.2 s of imports: only when a second start is wanted

        unit = qmc.Halton(len(variables), scramble=False).random(count)[1:]
        points.extend(lower + unit * (upper - lower))
    return np.array(points[:count])
