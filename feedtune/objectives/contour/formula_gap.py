"""What radius_decrease_gap and surface_roughness_gap share: a paper formula against its
exact circle-test counterpart."""

from __future__ import annotations

import math

from feedtune.expr import Magnitude, to_float
from feedtune.lazy import ca
from feedtune.loops.protocols import Loop
from feedtune.objectives.contour.circle_test import CircleTestMetric


def relative_gap(formula, exact) -> ca.DM:
    """(formula − exact)/|exact| [1] of two numbers; NaN where the exact one is 0 or ∞."""
    if not math.isfinite(exact) or exact == 0:
        return ca.DM(math.nan)
    return ca.DM((formula - exact) / abs(exact))


def _number(value) -> float:
    expr = value.expr if isinstance(value, Magnitude) else value  # a Magnitude: its |·|
    return abs(to_float(expr))


class FormulaGap(CircleTestMetric):
    """Relative gap [1] between a paper formula and its exact circle-test counterpart.

    Reported only, on the same circles as the spec's contour terms: how far Sato's
    analysis (which the NLP optimises) is from the polygon actually followed.
    """

    unit = "1"
    formula: type

    def exact(self, loop: Loop, options) -> float:
        return float(super().evaluate(loop, options))

    def evaluate(self, loop: Loop, options):
        exact = self.exact(loop, options)  # first: it refuses a loop of symbols (TypeError)
        return relative_gap(_number(self.formula().evaluate(loop, options)), exact)
