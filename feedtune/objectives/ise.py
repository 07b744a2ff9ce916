"""Integral of squared error after a position step."""

from feedtune.objectives.base import Metric
from feedtune.objectives.step_error import (StepErrorOptions, step_error_unit, supports_step_error,
                                             time_weight)


class Ise(Metric):
    """ISE = ∫e(t)²dt [m²·s] for a 1 m step, exact between samples."""

    name = "ise"
    unit = "m²·s (time absolute) or m²·rad (time natural)"
    description = "Integral of squared position error after a 1 m position step"
    Options = StepErrorOptions

    def unit_of(self, options):
        return step_error_unit(options, "m²·s", "m²·rad")

    def supports(self, loop, options=StepErrorOptions()):
        return supports_step_error(loop, options)

    def evaluate(self, loop, options):
        return time_weight(loop, options, 1) * loop.step_error_integrals.ise
