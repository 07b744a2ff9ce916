"""What the NLP sees at a point: objective, terms, bounds, stability, by name.

Plain metric values come from one CasADi Function of the log tunables and the parameters;
peaks and crossings over frequency from their numeric scans (feedtune.tuner.supremum),
not from the metrics' symbolic refinement (golden section in every grid window, written
in MX: ≈ 0.2–0.3 s a call on Bhatia's loop). The result's own numbers come from the loop
of numbers instead (Problem._evaluate_numeric); the model gap compares the two.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca
import numpy as np

from feedtune.expr import Magnitude
from feedtune.tuner.calls import numeric
from feedtune.tuner.scenarios import objective_value
from feedtune.tuner.terms import exact_value
from feedtune.tuner.types import finite, number


@dataclass(frozen=True)
class Seen:
    """Values at one point, each in its metric's unit (None: not a finite number; a bound's
    value may be ±∞, an :class:`~feedtune.expr.Unbounded` one's, None only for NaN).

    ``objective`` is Σ weight·term (the largest such sum over the terms' groups); ``terms``
    and ``bounds`` each metric value (|e| for a magnitude); ``stability`` and ``settling``
    the loop's conditions (all > 0 when stable and settled); ``matrices`` the state
    matrices that must be stable, by name.
    """

    objective: float | None
    terms: list[float | None]
    bounds: list[float | None]
    stability: np.ndarray
    settling: np.ndarray
    matrices: dict[str, np.ndarray]


class Evaluator:
    """:class:`Seen` at any log tunables ``z`` for parameter values ``p`` (the NLP's, of
    which the first ``p.numel()`` given here are read).

    ``terms`` and ``bounds`` are the metric values of the objective terms and constraints
    (expressions, Magnitudes, Supremums or Crossings), ``weights`` the terms' signed
    weights, ``scans`` the numeric scan of each value that has one (None otherwise),
    ``groups`` each term's group (the objective is the largest group sum,
    :mod:`feedtune.tuner.scenarios`; default: one group).
    """

    def __init__(self, z, p, terms: list, weights: list[float], term_scans: list, bounds: list,
                 bound_scans: list, stability: list, settling: list, matrices: dict,
                 groups: list[int] | None = None):
        self.weights = list(weights)
        self.groups = list(groups) if groups is not None else [0] * len(self.weights)
        self.term_scans, self.bound_scans = list(term_scans), list(bound_scans)
        # not exact_value: a Supremum's or Crossing's exact graph is built only when read
        self.term_magnitude = [isinstance(v, Magnitude) for v in terms]
        self.bound_magnitude = [isinstance(v, Magnitude) for v in bounds]
        self.matrix_names = list(matrices)
        self.n_params = p.numel()  # the parameters existing now: a call passes that many

        def plain(values, scans):  # a scanned value is filled in numerically
            return ca.vertcat(ca.MX(0, 1), *[ca.MX(0) if scan is not None else exact_value(v)[0]
                                             for v, scan in zip(values, scans)])

        self.function = ca.Function(
            "check", [z, p],
            [plain(terms, term_scans), plain(bounds, bound_scans),
             ca.vertcat(ca.MX(0, 1), *stability), ca.vertcat(ca.MX(0, 1), *settling),
             *matrices.values()],
            ["z", "p"], ["terms", "bounds", "stability", "settling", *self.matrix_names])
        # its numeric call, looked up once (held weakly by feedtune.tuner.calls; the
        # Function is this evaluator's)
        self._check = numeric(self.function)

    def with_weights(self, weights: list[float]) -> "Evaluator":
        """This evaluator (its Function and scans shared) summing the terms with ``weights``
        (another spec of the same structure: its weights are NLP parameters)."""
        other = object.__new__(Evaluator)  # a shallow copy (copy.copy's reduce: ≈ 10×)
        other.__dict__.update(self.__dict__, weights=list(weights))
        return other

    def __call__(self, z: np.ndarray, p: np.ndarray) -> Seen:
        # the outputs in the Function's order: terms, bounds, stability, settling, matrices
        out = self._check.outputs(z, p[:self.n_params])

        def values(row, magnitudes, scans, read=finite):
            result = []
            for v, magnitude, scan in zip(row.ravel().tolist(), magnitudes, scans):
                v = scan.exact(z, p) if scan is not None else v
                result.append(read(abs(v) if magnitude else v))
            return result

        terms = values(out[0], self.term_magnitude, self.term_scans)
        objective = objective_value(self.weights, terms, self.groups)
        return Seen(objective=finite(objective) if objective is not None else None,
                    terms=terms,
                    bounds=values(out[1], self.bound_magnitude, self.bound_scans, number),
                    stability=out[2].ravel(), settling=out[3].ravel(),
                    matrices=dict(zip(self.matrix_names, out[4:])))


def _least(values) -> float | None:
    """The smallest magnitude among ``values`` that are finite and non-zero (None and NaN
    skipped), as a float; None when there is none."""
    magnitudes = [abs(float(v)) for v in values if v is not None]
    return min((m for m in magnitudes if 0 < m < math.inf), default=None)


@dataclass(frozen=True)
class Scales:
    """The smallest magnitude each value takes over the stable starts (None: no stable
    start gave a finite, non-zero value), in the value's own unit."""

    objective: float | None
    terms: list[float | None]
    bounds: list[float | None]
    stability: list[float | None]
    settling: list[float | None]


def smallest_magnitudes(seen: list[Seen]) -> Scales:
    """:class:`Scales` over the points ``seen`` (the starts).

    Objective, terms and bounds count only at stable points: an unstable loop's IAE is
    astronomically large, and scaling by it would flatten the objective until IPOPT stops
    anywhere (too small a scale is harmless: IPOPT's gradient-based scaling shrinks large
    gradients). Conditions count everywhere.
    """
    def smallest(rows, stable_only):  # per column: min |v| over its finite, non-zero values
        counted = [row for row, ok in zip(rows, stable) if ok or not stable_only]
        return [_least(row[j] for row in counted) for j in range(len(rows[0]))]

    stable = [bool(np.all(s.stability > 0)) for s in seen]
    return Scales(objective=smallest([[s.objective] for s in seen], True)[0],
                  terms=smallest([s.terms for s in seen], True),
                  bounds=smallest([s.bounds for s in seen], True),
                  stability=smallest([s.stability for s in seen], False),
                  settling=smallest([s.settling for s in seen], False))
