"""IAE, ISE and ITAE of an error sampled on a grid, exact for piecewise-linear e(t)."""

from __future__ import annotations

import numpy as np


def error_integrals(t: np.ndarray, e: np.ndarray) -> dict[str, float]:
    """∫|e| dt, ∫e² dt, ∫t|e| dt over the grid ``t`` [s] (any spacing), e linear between
    points: |e| split exactly at the sign changes, e² by the exact quadratic of each piece."""
    dt = np.diff(t)
    e0, e1, t0 = e[:-1], e[1:], t[:-1]
    ise = float(np.sum((e0**2 + e1**2 + e0 * e1) / 3 * dt))
    same = e0 * e1 >= 0
    denom = np.where(same, 1.0, np.abs(e0) + np.abs(e1))
    iae = float(np.sum(np.where(same, (np.abs(e0) + np.abs(e1)) / 2,
                                (e0**2 + e1**2) / (2 * denom)) * dt))
    # ∫t|e| over a piece: trapezoid of t|e| where e keeps its sign, else the two triangles
    te0, te1 = t0 * np.abs(e0), (t0 + dt) * np.abs(e1)
    frac = np.where(same, 0.0, np.abs(e0) / denom)  # where the zero lies in the piece
    cross = (np.abs(e0) * frac * dt * (t0 + frac * dt / 3)
             + np.abs(e1) * (1 - frac) * dt * (t0 + frac * dt + 2 * (1 - frac) * dt / 3)) / 2
    itae = float(np.sum(np.where(same, (te0 + te1) / 2 * dt, cross)))
    return {"iae": iae, "ise": ise, "itae": itae}
