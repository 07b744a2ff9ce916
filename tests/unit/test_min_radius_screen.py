"""The exact minimum radius of a loop of numbers scans only the radii a bound cannot settle
(issue 15): the same r_min, bit for bit, as the scan of every radius.

``min_radius._screened`` reads the criterion's excess, slope and curvature in ln r at every
16th radius of the 1 601-radius grid and proves whole cells failing or passing; only the
other cells (and one radius either side) are evaluated by the criterion itself. The value
must be the full scan's to the bit on Koren's loops (reference pulse, sampled with and
without a computation delay, slow and fast gains), on the issue-14 loop whose criterion dips
through BLU/2 and rises again, and on the loop whose failing band is 1e-7 of BLU/2 high and
far narrower than the grid (tests/unit/test_validator_min_radius.py).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

import feedtune.objectives.contour.min_radius as min_radius
from feedtune.loops.frequency import DERIVED_AFTER
from feedtune.objectives import METRICS
from feedtune.plants.software_servo import SoftwareServo, SoftwareServoParams
from feedtune.validate.software_servo import ServoModel

#: (τ [s], BLU [m], V_m [m/s]): Koren's design example, and the issue-14 drive
KOREN, ISSUE_14 = (0.02, 5e-6, 0.04), (0.01, 1e-6, 0.333)


def _loop(drive, technique, gain, period=None, delay=0):
    tau, blu, v_m = drive
    params = SoftwareServoParams(type="software_servo", technique=technique, time_constant=tau,
                                 blu=blu, max_velocity=v_m, computation_delay=delay)
    values, box = {"position_gain": gain}, {"position_gain": (gain / 2, gain * 2)}
    if period is not None:
        values["sampling_period"] = period
        box["sampling_period"] = (period / 2, period * 2)
    return SoftwareServo(params).loop(values, box)


def _narrow_band_period() -> float:
    """T [s] of the issue-14 loop (K = 38.7 1/s) whose dip's peak exceeds BLU/2 by 1e-7."""
    tau, blu, v_m = ISSUE_14

    def peak_excess(period):
        model = ServoModel(38.7, tau, period, blu=blu, max_velocity=v_m)
        values = np.array([model.radial_error(r, v_m) for r in np.geomspace(0.07, 0.3, 400)])
        return np.max(values[int(np.argmin(values)):]) / (blu / 2) - 1 - 1e-7

    return brentq(peak_excess, 0.00590, 0.005908, xtol=1e-16)


LOOPS = [(KOREN, "reference_pulse", gain, None, 0) for gain in (0.1, 1.0, 12.5, 25.0, 100.0)] + [
    (KOREN, "sampled_data", gain, period, delay)
    for gain, period, delay in ((18.0, 1 / 64, 0), (30.0, 1 / 64, 0), (60.0, 0.005, 0),
                                (10.0, 0.01, 1), (5.0, 0.01, 2), (2.0, 0.3, 0))] + [
    (ISSUE_14, "sampled_data", 38.7, 0.005908, 0), (ISSUE_14, "sampled_data", 38.7, 0.0059, 0)]


def _values(loop, monkeypatch) -> tuple[float, float, list]:
    """(r_min screened, r_min of the full scan, the screen's value rows) [m]."""
    metric = METRICS["min_radius"]()
    for _ in range(DERIVED_AFTER):  # a structure's jet is built at the next request
        metric.evaluate(loop, None)
    rows, screened = [], min_radius._screened

    def kept(*args):
        rows.append(screened(*args))
        return rows[-1]

    monkeypatch.setattr(min_radius, "_screened", kept)
    with_screen = float(metric.evaluate(loop, None))
    monkeypatch.setattr(min_radius, "_screened", lambda *args: None)
    return with_screen, float(metric.evaluate(loop, None)), rows


@pytest.mark.parametrize("drive, technique, gain, period, delay", LOOPS)
def test_the_screened_scan_gives_the_full_scans_bits(drive, technique, gain, period, delay,
                                                      monkeypatch):
    screened, full, rows = _values(_loop(drive, technique, gain, period, delay), monkeypatch)
    # K = 0.1 1/s fails up to 31.9 km, past the grid's last radius: the scan may grow, so
    # every radius is scanned (no screen); every other loop is screened
    assert len(rows) == 1 and (rows[0] is None) == (gain == 0.1)
    assert screened == full or (math.isnan(screened) and math.isnan(full))


def test_a_failing_band_narrower_than_the_grid_is_kept(monkeypatch):
    """The band 1e-7 of BLU/2 above the criterion is no cell's proven pass: its radii are
    evaluated, its local maximum refined, and r_min lies above it as without the screen."""
    loop = _loop(ISSUE_14, "sampled_data", 38.7, _narrow_band_period())
    screened, full, rows = _values(loop, monkeypatch)
    assert rows[0] is not None and screened == full
    assert screened > 0.1  # above the dip (the band near 160 mm), not its lower edge at 60 mm


def row_sizes(monkeypatch) -> list[int]:
    """The sizes of the rows of radii the criterion is evaluated on from now on (each call
    of a :func:`min_radius._vectorised` Function appends its row's)."""
    sizes = []
    vectorised = min_radius._vectorised

    def counted(fn):
        evaluate = vectorised(fn)

        def wrapper(u):
            sizes.append(np.size(u))
            return evaluate(u)

        return wrapper

    monkeypatch.setattr(min_radius, "_vectorised", counted)
    return sizes


def test_the_screen_evaluates_few_radii(monkeypatch):
    """On Koren's sampled loop the criterion itself is evaluated on one row of a few
    dozen radii (the cells around the largest failing radius), not on all 1 601."""
    loop = _loop(KOREN, "sampled_data", 18.0, 1 / 64)
    metric = METRICS["min_radius"]()
    metric.evaluate(loop, None)
    sizes = row_sizes(monkeypatch)
    metric.evaluate(loop, None)
    rows = [s for s in sizes if s > 1]
    assert len(rows) == 1 and rows[0] <= 4 * min_radius._CHUNK
