"""Rows of the ``validation`` block: a metric as reported, as re-measured, and the gap."""

from __future__ import annotations

import numpy as np

#: poles on both sides are eigenvalues; only rounding separates them (~1e-12)
POLE_TOLERANCE = 1e-6


def relative_gap(reported: float, validated: float, floor: float = 0.0) -> float:
    """|validated − reported| / max(|reported|, |validated|, floor)."""
    scale = max(abs(reported), abs(validated), floor)
    return 0.0 if scale == 0 else abs(validated - reported) / scale


def entry(metric: str, options: dict, reported: float, validated: float, tolerance: float,
          floor: float = 0.0) -> dict:
    """One row: ``gap`` relative (see :func:`relative_gap`), ``ok`` = gap ≤ tolerance."""
    gap = relative_gap(reported, validated, floor)
    return {"metric": metric, "options": options, "reported": reported, "validated": validated,
            "gap": gap, "tolerance": tolerance, "ok": bool(gap <= tolerance)}


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
    """The ``poles`` row: reported and validated as sorted [re, im] pairs."""
    validated = np.asarray(validated, dtype=complex)
    gap = pole_gap(reported, validated, discrete)
    ordered = validated[np.lexsort((validated.imag, validated.real))]
    return {"metric": "poles", "options": {"domain": "z" if discrete else "s"},
            "reported": reported,
            "validated": [[float(p.real), float(p.imag)] for p in ordered],
            "gap": gap, "tolerance": POLE_TOLERANCE, "ok": bool(gap <= POLE_TOLERANCE)}


def stable_entry(reported: bool, validated: bool) -> dict:
    """The ``stable`` row: no gap, ``ok`` when both agree."""
    return {"metric": "stable", "options": {}, "reported": bool(reported),
            "validated": bool(validated), "gap": None, "tolerance": None,
            "ok": bool(validated) == bool(reported)}
