"""Stability in the tuner: the NLP's rows, the numpy eigenvalue verdict, and restoration.

The loop's Hurwitz/Schur conditions are always NLP rows (scaled, then asinh so that a
condition spanning decades stays O(10)). Whether a tuned loop is stable is decided by
numpy eigenvalues of every matrix that must be stable *and* those conditions
(:func:`feasibility`). A start whose loop is unstable is first moved to a stable point
nearby (:func:`restore`): IPOPT from an unstable point only wanders (measured on Bhatia's
showcase). The eigenvalue check here is the tuner's own; feedtune.validate has an
independent one, so a result is not judged by the code that produced it.
"""

from __future__ import annotations

import math
from typing import Callable

import casadi as ca
import numpy as np

from feedtune.tuner.builder import Lazy, NlpBuilder, scale
from feedtune.tuner.types import Bound, within

#: scaled Hurwitz conditions must exceed this [1]
STABILITY_MARGIN = 1e-9
#: a pole must clear the boundary by this much: |z| < 1 − margin, Re s < −margin·|s| [1]
POLE_MARGIN = 1e-9
#: loop evaluations a start may spend looking for stability
RESTORATION_EVALUATIONS = 400


def poles_stable(matrix: np.ndarray, discrete: bool) -> dict:
    """Poles of a closed-loop state matrix and whether all are stable.

    ``stable``, ``domain`` ('s' or 'z'), ``poles`` as [re, im] pairs [1/s or 1], and
    ``spectral_abscissa`` [1/s] (continuous) or ``spectral_radius`` [1] (sampled). Each
    continuous pole is judged against its own magnitude: a stiff loop (poles from 1e-2 to
    1e7 rad/s) has slow poles far below any margin relative to the fastest one.
    """
    matrix = np.asarray(matrix, dtype=float)
    if not np.all(np.isfinite(matrix)):
        return {"stable": False, "domain": "z" if discrete else "s", "poles": []}
    poles = np.linalg.eigvals(matrix)
    stable, extreme = _verdict(poles, discrete)
    poles = poles[np.lexsort((poles.imag, poles.real))]
    pairs = [[float(p.real), float(p.imag)] for p in poles]
    if discrete:
        return {"stable": stable, "domain": "z", "poles": pairs, "spectral_radius": extreme}
    return {"stable": stable, "domain": "s", "poles": pairs, "spectral_abscissa": extreme}


def _verdict(poles: np.ndarray, discrete: bool) -> tuple[bool, float]:
    """(every pole stable, the spectral radius [1] or abscissa [1/s]) of ``poles`` in any
    order."""
    if discrete:
        radius = float(np.max(np.abs(poles)))
        return radius < 1 - POLE_MARGIN, radius
    abscissa = float(np.max(poles.real))
    return bool(np.all(poles.real < -POLE_MARGIN * np.abs(poles))) and abscissa < 0, abscissa


def _matrix_stable(matrix: np.ndarray, discrete: bool) -> bool:
    """``poles_stable(matrix, discrete)["stable"]`` without the poles' list (the tuner's
    verdict at each start's end: ≈ 9 of 30 µs a 2 × 2 matrix, measured)."""
    matrix = np.asarray(matrix, dtype=float)
    return bool(np.all(np.isfinite(matrix))) and _verdict(np.linalg.eigvals(matrix), discrete)[0]


def holds(bounds: list[float | None], constraints: list[Bound], conditions: np.ndarray,
          matrices, discrete: bool) -> bool:
    """``feasibility(...)[0]`` (``matrices`` any iterable of them) without the block."""
    return (bool(np.all(conditions > 0)) and all(_matrix_stable(m, discrete) for m in matrices)
            and all(within(v, b.lower, b.upper) for v, b in zip(bounds, constraints)))


def feasibility(bounds: list[float | None], constraints: list[Bound], conditions: np.ndarray,
                matrices: dict[str, np.ndarray], discrete: bool) -> tuple[bool, dict]:
    """Constraints hold and every loop is stable by eigenvalues and by its conditions.

    Returns (feasible, the result's stability block): the closed loop's :func:`poles_stable`
    entries, each other loop that must be stable on its own (e.g. an inner velocity loop)
    under its name, ``conditions_hold`` and ``stable``.
    """
    checks = {name: poles_stable(m, discrete) for name, m in matrices.items()}
    numeric = checks.pop("closed_loop")
    hurwitz_ok = bool(np.all(conditions > 0))
    stability = {**numeric, **checks, "conditions_hold": hurwitz_ok}
    stability["stable"] = bool(numeric["stable"] and hurwitz_ok
                               and all(c["stable"] for c in checks.values()))
    ok = stability["stable"] and all(within(v, b.lower, b.upper) for v, b in zip(bounds, constraints))
    return ok, stability


def add_stability_rows(builder: NlpBuilder, stability: list, settling: list,
                       stability_ref: list, settling_ref: list) -> list:
    """Rows asinh(c/s_c) ≥ STABILITY_MARGIN for every stability condition and c/s_c for
    every settling condition, each scale a parameter; returns the scaled settling
    conditions (checked after solving: an active one means the horizon limited it).

    A row scaled by a start's large condition reads a violation far from that start as
    nearly 0 (Ward-Leonard variant 01: minors of 4e12 at the start, −4e4 at an unstable end
    point, read −1e-8); where peaks and crossings over frequency are bounded, the NLP's
    objective keeps its iterates stable instead (:func:`nan_where_unstable`). Capping the
    scale at 1 was tried: it broke the one-gain hydraulic bandwidth tuning of
    tests/unit/test_tuner_frequency.py (IPOPT: infeasible) and is not needed with that.

    The rows are :class:`~feedtune.tuner.builder.Lazy` (each scale's parameter made here,
    in this order); the scaled settling conditions are None from a builder that is not
    symbolic."""
    stability_rows = [Lazy(lambda c=c, s=builder.parameter(f"stability_scale{i}", scale(ref)):
                           ca.asinh(c / s))
                      for i, (c, ref) in enumerate(zip(stability, stability_ref))]
    scaled_settling = [Lazy(lambda c=c, s=builder.parameter(f"settling_scale{i}", scale(ref)):
                            c / s)
                       for i, (c, ref) in enumerate(zip(settling, settling_ref))]
    for condition in stability_rows + scaled_settling:
        builder.constrain(condition, STABILITY_MARGIN, ca.inf)
    return [builder.expression(c) for c in scaled_settling]


def nan_where_unstable(f, conditions: list):
    """``f`` where every stability condition is positive, NaN elsewhere.

    IPOPT treats a NaN as a step too long and backs off along it, so an NLP whose
    objective this is never takes an iterate out of the stable region (its start is
    stable: see :func:`restore`). Peaks and crossings over frequency need it: the
    frequency response of an unstable loop is finite and may look better than any stable
    one, and a pole pair crosses the jω axis between two grid frequencies in one step
    (measured on Ward-Leonard variant 08: IPOPT ended on a closed loop with poles at
    +26 ± 30j rad/s, M_peak 1.0005, where its stability rows could not bring it back).
    """
    if not conditions:
        return f
    return f + ca.if_else(ca.mmin(ca.vertcat(*conditions)) > 0, 0, math.nan)


def restore(z0: np.ndarray, evaluate: Callable, lower: np.ndarray, upper: np.ndarray,
            discrete: bool) -> np.ndarray | None:
    """``z0`` if its loop is stable, else a stable point near it, or None.

    ``evaluate(z)`` gives (stability conditions, [matrices that must be stable]) at the log
    tunables z. Restoration minimises the largest Re λ/|λ| (|λ| − 1 for a sampled loop) of
    every such matrix, plus a pull towards ``z0``, with Nelder–Mead within [lower, upper],
    stopping at the first point whose eigenvalues and conditions both hold.
    Derivative-free on purpose: an NLP on the Hurwitz conditions stalled (their
    frequency-balanced form is not monotone in a gain, measured: −1.62 at K'_p = 900,
    −1.85 at 500, +0.98 at 120 on Bhatia's drive).
    """
    from scipy import optimize

    def stable(z):
        conditions, matrices = evaluate(z)
        return holds([], [], conditions, matrices, discrete)

    if stable(z0):
        return z0
    found = []

    def instability(z):
        matrices = evaluate(z)[1]
        if not all(np.all(np.isfinite(m)) for m in matrices):
            return 1e3
        poles = np.concatenate([np.linalg.eigvals(m) for m in matrices])
        worst = (np.max(np.abs(poles)) - 1 if discrete else
                 np.max(poles.real / np.maximum(np.abs(poles), 1e-300)))
        if worst < 0 and stable(z):
            found.append(z.copy())
            raise StopIteration
        return worst + 1e-3 * float(np.sum(((z - z0) / (upper - lower)) ** 2))

    try:
        optimize.minimize(instability, z0, method="Nelder-Mead", bounds=list(zip(lower, upper)),
                          options={"maxfev": RESTORATION_EVALUATIONS, "xatol": 1e-6,
                                   "fatol": 1e-9})
    except StopIteration:
        pass
    return found[0] if found else None
