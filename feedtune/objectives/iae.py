"""Integral of absolute error after a position step (Koren eq 20)."""

from feedtune.objectives.base import Metric
from feedtune.objectives.step_error import (StepErrorOptions, step_error_unit, supports_step_error,
                                             time_weight)


class Iae(Metric):
    """IAE = ∫|e(t)|dt [m·s] for a 1 m step, exact between samples (Koren eq 20)."""

    name = "iae"
    unit = "m·s (time absolute) or m·rad (time natural)"
    description = "Integral of |position error| after a 1 m position step"
    reference = "Koren 1979 eq 20"
    Options = StepErrorOptions

    def unit_of(self, options):
        return step_error_unit(options, "m·s", "m·rad")

    def supports(self, loop, options=StepErrorOptions()):
        return supports_step_error(loop, options)

    def evaluate(self, loop, options):
        return time_weight(loop, options, 1) * loop.step_error_integrals.iae
