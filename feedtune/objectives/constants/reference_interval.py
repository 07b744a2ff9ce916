"""The interpolator's reference interval T as a metric (Sato et al. eq 1)."""

from feedtune.loops.protocols import Loop
from feedtune.objectives.base import Metric


class ReferenceInterval(Metric):
    """T [s], one interpolated point every T: the interpolator's load is 1/T.

    The tunable ``reference_interval`` itself, so that an objective can ask for the
    largest T (``goal: maximize``) under contour constraints, or bound it.
    """

    name = "reference_interval"
    unit = "s"
    description = "Reference input interval T of the linear interpolator"
    reference = "Sato et al. eq 1"

    def supports(self, loop: Loop, options=None):
        return loop.interpolator is not None

    def evaluate(self, loop: Loop, options):
        return loop.interpolator.reference_interval
