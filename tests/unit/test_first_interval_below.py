"""feedtune.loops.frequency._first_interval_below: the symbolic crossing's first grid interval,
read from the whole row of values at once, is the interval a scan of the row gives."""

import casadi as ca
import numpy as np
import pytest

from feedtune.loops.frequency import _first_interval_below, log_grid

GRID = np.log(log_grid((1e-1, 1e3)))  # ln ω [ln(rad/s)], 161 points


def _scanned(values: np.ndarray) -> tuple[float, float, float]:
    """The lowest k ≥ 1 with values[k] < 0 by a Python scan: (grid[k−1], grid[k], 1), else
    (grid[−1], grid[−1], 0). NaN is not below 0."""
    for k in range(1, len(values)):
        if values[k] < 0:
            return GRID[k - 1], GRID[k], 1.0
    return GRID[-1], GRID[-1], 0.0


def _located(values: np.ndarray) -> tuple[float, float, float]:
    row = ca.MX.sym("values", 1, len(GRID))
    f = ca.Function("located", [row], list(_first_interval_below(row, GRID)))
    return tuple(float(v) for v in f(values))


def _rows():
    rng = np.random.default_rng(15)
    rows = {"none below": np.ones(len(GRID)),
            "only the first below (the band's low end is not an interval's top)":
                np.concatenate([[-1.0], np.ones(len(GRID) - 1)]),
            "only the last below": np.concatenate([np.ones(len(GRID) - 1), [-1.0]]),
            "zero is not below": np.concatenate([np.ones(80), [0.0], -np.ones(len(GRID) - 81)]),
            "NaN is not below": np.concatenate([np.ones(40), [np.nan], -np.ones(len(GRID) - 41)])}
    for index in range(8):  # several sign changes: the lowest one wins
        rows[f"random {index}"] = rng.choice([-1.0, 1.0, 2.0], size=len(GRID), p=[0.05, 0.5, 0.45])
    return rows


@pytest.mark.parametrize("values", list(_rows().values()), ids=list(_rows()))
def test_the_row_gives_the_scans_interval(values):
    assert _located(values) == _scanned(values)  # a selection of grid points: exact
