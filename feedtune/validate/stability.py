"""Closed-loop stability from numpy eigenvalues, independent of the NLP's Hurwitz conditions."""

from __future__ import annotations

import numpy as np

#: a pole must clear the stability boundary by this much (|z| < 1 − margin, Re s < −margin·scale)
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
    abscissa = float(np.max(poles.real))
    scale = max(1.0, float(np.max(np.abs(poles))))
    return {"stable": abscissa < -MARGIN * scale, "domain": "s", "poles": pairs,
            "spectral_abscissa": abscissa}
