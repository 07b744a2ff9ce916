"""Gap between Sato's formulas and the exact circle test, for the two contour metrics."""

import math

import casadi as ca

from feedtune.objectives import circle_test
from feedtune.objectives.base import Metric
from feedtune.objectives.circle import CircleOptions
from feedtune.objectives.radius_decrease import RadiusDecrease
from feedtune.objectives.surface_roughness import SurfaceRoughness


def relative_gap(formula, exact) -> ca.DM:
    """(formula − exact)/|exact| [1] of two numbers; NaN where the exact one is 0 or ∞."""
    if not math.isfinite(exact) or exact == 0:
        return ca.DM(math.nan)
    return ca.DM((formula - exact) / abs(exact))


def _number(value) -> float:
    expr = value.expr if hasattr(value, "expr") else value  # a Magnitude: its |·|
    return abs(float(ca.evalf(ca.MX(expr))))


class FormulaGap(Metric):
    """Relative gap [1] between a paper formula and its exact circle-test counterpart.

    Reported only, on the same circles as the spec's contour terms: how far Sato's
    analysis (which the NLP optimises) is from the polygon actually followed.
    """

    unit = "1"
    Options = CircleOptions
    formula: type
    quantity: str

    def supports(self, loop, options=None):
        return circle_test.supports(loop)

    def optimisable(self, loop, options=None):
        return False

    def exact(self, loop, options) -> float:
        return float(circle_test.circle_value(loop, options, self.quantity))

    def evaluate(self, loop, options):
        exact = self.exact(loop, options)  # first: it refuses a loop of symbols (TypeError)
        return relative_gap(_number(self.formula().evaluate(loop, options)), exact)


class RadiusDecreaseGap(FormulaGap):
    """(Δr by eq 7 − exact mean decrease)/exact, the exact one −circle_mean_deviation."""

    name = "radius_decrease_gap"
    description = ("Relative gap of Sato's decrease in radius (eq 7) to the exact circle "
                   "test's mean decrease (reported only)")
    reference = "Sato et al. eq 7; exact periodic steady state"
    formula = RadiusDecrease
    quantity = "mean_deviation"

    def exact(self, loop, options):
        return -super().exact(loop, options)


class SurfaceRoughnessGap(FormulaGap):
    """(Δm by eq 10 − exact peak-to-valley ripple)/exact (circle_roughness)."""

    name = "surface_roughness_gap"
    description = ("Relative gap of Sato's surface roughness (eq 10) to the exact circle "
                   "test's peak-to-valley ripple (reported only)")
    reference = "Sato et al. eq 10; exact periodic steady state"
    formula = SurfaceRoughness
    quantity = "roughness"
