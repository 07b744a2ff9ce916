"""Rows of the ``validation`` block that are not a metric: the closed-loop poles and the
stability verdict (a metric's row is :func:`feedtune.validate.tolerances.judge`)."""

from __future__ import annotations

import numpy as np

#: poles on both sides are eigenvalues; only rounding separates them (~1e-12). The scale is
#: the spectral one: the unit circle (z-plane) or each pole's own magnitude (s-plane)
POLE_TOLERANCE = 1e-6


def pole_gap(reported: list, validated: np.ndarray, discrete: bool) -> float:
    """Largest distance from a validated pole to the nearest reported one, relative to 1
    (z-plane) or to the pole's magnitude (s-plane); different counts are a gap of 1 (only
    zero poles may differ, from a different state choice)."""
    rep = np.array([complex(re, im) for re, im in reported])
    val = np.asarray(validated, dtype=complex)
    if discrete:  # z = 0 poles depend on how the delay buffer is written down
        rep, val = rep[np.abs(rep) > 1e-12], val[np.abs(val) > 1e-12]
    if len(rep) != len(val):
        return 1.0
    if len(val) == 0:
        return 0.0
    gaps = [np.min(np.abs(rep - v)) / (1.0 if discrete else max(abs(v), 1e-300)) for v in val]
    return float(max(gaps))


def poles_entry(reported: list, validated: np.ndarray, discrete: bool) -> dict:
    """The ``poles`` row: reported and validated as sorted [re, im] pairs; ``gap`` is
    :func:`pole_gap` [1], on the spectral scale named by ``basis``."""
    validated = np.asarray(validated, dtype=complex)
    gap = pole_gap(reported, validated, discrete)
    ordered = validated[np.lexsort((validated.imag, validated.real))]
    return {"metric": "poles", "options": {"domain": "z" if discrete else "s"},
            "reported": reported,
            "validated": [[float(p.real), float(p.imag)] for p in ordered],
            "unit": "1", "gap": gap, "tolerance": POLE_TOLERANCE,
            "basis": "the unit circle" if discrete else "each pole's magnitude",
            "ok": bool(gap <= POLE_TOLERANCE)}


def stable_entry(reported: bool, validated: bool) -> dict:
    """The ``stable`` row: no gap, ``ok`` when both agree."""
    return {"metric": "stable", "options": {}, "reported": bool(reported),
            "validated": bool(validated), "unit": None, "gap": None, "tolerance": None,
            "basis": None, "ok": bool(validated) == bool(reported)}
