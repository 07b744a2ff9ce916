"""Independent checks of discrete loops by python-control's own evaluation, shared by the
unit and reference tests (tests/ is on sys.path through its conftest)."""

import math

import numpy as np
from scipy.optimize import brentq, minimize_scalar


def control_peak_and_bandwidth(closed, period):
    """(M_peak, bandwidth [rad/s]) of a discrete closed loop by python-control's own
    evaluation at z = e^{jωT}: a grid of 20 001 points up to π/T, the peak polished by
    bounded Brent, the first crossing of 1/√2 by brentq (π/T when there is none)."""
    nyquist = math.pi / period
    grid = np.geomspace(nyquist * 1e-5, nyquist, 20_001)

    def gain(w):
        return float(np.abs(closed(np.exp(1j * w * period))))

    dc = float(np.abs(closed(1.0)))
    mag = np.abs(np.asarray(closed(np.exp(1j * grid * period))).ravel()) / dc
    k = int(np.argmax(mag))
    lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
    polished = minimize_scalar(lambda u: -gain(math.exp(u)) / dc, method="bounded",
                               bounds=(math.log(lo), math.log(hi)), options={"xatol": 1e-12})
    peak = max(1.0, float(mag[k]), -polished.fun)
    below = np.flatnonzero(mag < 1 / math.sqrt(2))
    if below.size == 0:
        return peak, nyquist
    j = int(below[0])
    bandwidth = brentq(lambda w: gain(w) / dc - 1 / math.sqrt(2), grid[j - 1], grid[j],
                       xtol=1e-13 * grid[j], rtol=1e-15)
    return peak, bandwidth
