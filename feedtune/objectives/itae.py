"""Integral of time-weighted absolute error after a position step."""

from feedtune.objectives.base import Metric
from feedtune.objectives.step_error import (StepErrorOptions, step_error_unit, supports_step_error,
                                             time_weight)


class Itae(Metric):
    """ITAE = ∫t|e(t)|dt [m·s²] for a 1 m step, exact between samples."""

    name = "itae"
    unit = "m·s² (time absolute) or m·rad² (time natural)"
    description = "Integral of t·|position error| after a 1 m position step"
    Options = StepErrorOptions

    def unit_of(self, options):
        return step_error_unit(options, "m·s²", "m·rad²")

    def supports(self, loop, options=StepErrorOptions()):
        return supports_step_error(loop, options)

    def evaluate(self, loop, options):
        return time_weight(loop, options, 2) * loop.step_error_integrals.itae
