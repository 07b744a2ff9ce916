"""Gap of Sato's decrease in radius (eq 7) to the exact circle test."""

from feedtune.loops.protocols import Loop
from feedtune.objectives.contour.formula_gap import FormulaGap
from feedtune.objectives.contour.radius_decrease import RadiusDecrease


class RadiusDecreaseGap(FormulaGap):
    """(Δr by eq 7 − exact mean decrease)/exact, the exact one −circle_mean_deviation."""

    name = "radius_decrease_gap"
    description = ("Relative gap of Sato's decrease in radius (eq 7) to the exact circle "
                   "test's mean decrease (reported only)")
    reference = "Sato et al. eq 7; exact periodic steady state"
    formula = RadiusDecrease
    quantity = "mean_deviation"

    def exact(self, loop: Loop, options):
        return -super().exact(loop, options)
