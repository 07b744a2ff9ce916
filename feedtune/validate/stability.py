"""Closed-loop stability from numpy eigenvalues, independent of the NLP's Hurwitz conditions."""

from __future__ import annotations

import numpy as np

#: a pole must clear the stability boundary by this much (|z| < 1 − margin, Re s < −margin·|s|)
MARGIN = 1e-9


def check_stability(matrix: np.ndarray, discrete: bool) -> dict:
    """Poles of the closed-loop state matrix and whether all are stable.

    Parameters
    ----------
    matrix : (n, n) array
        A of ẋ = A x (continuous) or Φ of x(n+1) = Φ x(n) (sampled).
    discrete : bool

    Returns
    -------
    dict
        ``stable``, ``domain`` ('s' or 'z'), ``poles`` as [re, im] pairs [1/s or 1], and
        ``spectral_abscissa`` [1/s] (continuous) or ``spectral_radius`` [1] (sampled).
    """
    matrix = np.asarray(matrix, dtype=float)
    if not np.all(np.isfinite(matrix)):
        return {"stable": False, "domain": "z" if discrete else "s", "poles": []}
    poles = np.linalg.eigvals(matrix)
    poles = poles[np.lexsort((poles.imag, poles.real))]
    pairs = [[float(p.real), float(p.imag)] for p in poles]
    if discrete:
        radius = float(np.max(np.abs(poles)))
        return {"stable": radius < 1 - MARGIN, "domain": "z", "poles": pairs,
                "spectral_radius": radius}
    # each pole against its own magnitude: a stiff loop (poles from 1e-2 to 1e7 rad/s) has
    # slow poles far below any margin taken relative to the fastest one
    abscissa = float(np.max(poles.real))
    stable = bool(np.all(poles.real < -MARGIN * np.abs(poles))) and abscissa < 0
    return {"stable": stable, "domain": "s", "poles": pairs, "spectral_abscissa": abscissa}
