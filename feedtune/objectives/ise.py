"""Integral of squared error after a position step or ramp (Bhatia Ch. IV B)."""

from feedtune.objectives.base import Metric
from feedtune.objectives.step_error import (StepErrorOptions, has_exact_step,
                                             numeric_error_integral, optimisable_step_error,
                                             step_error_unit, supports_step_error, time_weight)


class Ise(Metric):
    """ISE = ∫e(t)²dt [m²·s] after a unit (1 m or 1 rad) position step.

    Koren's loops: exact between samples and smooth in the tunables. Loops given by
    polynomials: from the Lyapunov equation of the exact response, reported only. With
    ``input`` ramp (loops given by polynomials only) the integrand is (e(t) − e_ss)²,
    e_ss = 1/C_v.

    References
    ----------
    S. Bhatia, "Feed drive design for NC machine tools", 1971, Ch. IV B (E = ∫e²(t)dt).
    """

    name = "ise"
    unit = "m²·s (time absolute) or m²·rad (time natural); rad for m on a rotary axis"
    description = ("Integral of squared position error after a unit position step, or of "
                   "(e − e_ss)² after a unit ramp")
    reference = "Bhatia 1971 Ch. IV B"
    Options = StepErrorOptions

    def unit_of(self, options):
        return step_error_unit(options, "m²·s", "m²·rad")

    def supports(self, loop, options=StepErrorOptions()):
        return supports_step_error(loop, options)

    def optimisable(self, loop, options=StepErrorOptions()):
        return optimisable_step_error(loop, options)

    def evaluate(self, loop, options):
        if not has_exact_step(loop, options):
            return numeric_error_integral(loop, options, self.name, "ise")
        return time_weight(loop, options, 1) * loop.step_error_integrals.ise
