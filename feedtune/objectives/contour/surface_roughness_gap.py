"""Gap of Sato's surface roughness (eq 10) to the exact circle test."""

from feedtune.objectives.contour.formula_gap import FormulaGap
from feedtune.objectives.contour.surface_roughness import SurfaceRoughness


class SurfaceRoughnessGap(FormulaGap):
    """(Δm by eq 10 − exact peak-to-valley ripple)/exact (circle_roughness)."""

    name = "surface_roughness_gap"
    description = ("Relative gap of Sato's surface roughness (eq 10) to the exact circle "
                   "test's peak-to-valley ripple (reported only)")
    reference = "Sato et al. eq 10; exact periodic steady state"
    formula = SurfaceRoughness
    quantity = "roughness"
