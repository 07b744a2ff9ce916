"""Independent checks of discrete loops by python-control's own evaluation, shared by the
unit and reference tests (tests/ is on sys.path through its conftest)."""

import math

import control
import numpy as np
from scipy.optimize import brentq, minimize_scalar


def response(system, points: np.ndarray) -> np.ndarray:
    """``system(points)`` of a SISO python-control system, flattened. A ``StateSpace``'s
    C (zI − A)⁻¹ B + D is solved at every point in one stacked ``numpy.linalg.solve``: the
    operations of ``StateSpace.horner`` without slycot, which makes them one call a point
    in Python (≈ 0.5 s of CPU on 20 001 points); a transfer function is python-control's
    call."""
    if not isinstance(system, control.StateSpace) or system.nstates < 2:
        return np.asarray(system(points)).ravel()
    a, b, c, d = (np.asarray(m, dtype=float) for m in (system.A, system.B, system.C, system.D))
    shifted = points.astype(complex)[:, None, None] * np.eye(a.shape[0]) - a
    return (c @ np.linalg.solve(shifted, b) + d)[:, 0, 0]


def control_peak_and_bandwidth(closed, period):
    """(M_peak, bandwidth [rad/s]) of a discrete closed loop by python-control's system at
    z = e^{jωT}: a grid of 20 001 points up to π/T (:func:`response`), the peak polished
    by bounded Brent and the first crossing of 1/√2 by brentq (π/T when there is none),
    both on python-control's own evaluation."""
    nyquist = math.pi / period
    grid = np.geomspace(nyquist * 1e-5, nyquist, 20_001)

    def gain(w):
        return float(np.abs(closed(np.exp(1j * w * period))))

    dc = float(np.abs(closed(1.0)))
    mag = np.abs(response(closed, np.exp(1j * grid * period))) / dc
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
