"""Overshoot of the step response (Bhatia 1971 Ch. IV B, "percentage overshoot")."""

from feedtune.loops.protocols import Loop
from feedtune.loops.timeresponse import has_sampled_step, sampled_step_error
from feedtune.objectives.base import Metric
from feedtune.objectives.time.step_error import (as_number, has_numeric_response, numeric_response,
                                                 resolving)


class Overshoot(Metric):
    """(max_t y(t) − y_ss)/y_ss [1] of the position y after a unit position step; 0 if none.

    y_ss = 1 for a type-1 loop, so this is how far the step response peaks above 1, as a
    fraction (0.05 = 5 %). Evaluated exactly on loops given by polynomials: every local
    extremum of the response located by Brent's method (:mod:`feedtune.loops.timeresponse`);
    on a sampled-data loop over continuous time, between samples too (the drive's position
    in closed form, :class:`feedtune.loops.timeresponse.SampledStepError`); reported only, never
    optimised. +∞ for an unstable loop.

    References
    ----------
    S. Bhatia, "Feed drive design for NC machine tools", 1971, Ch. IV B (percentage
    overshoot) and Ch. IV F, Fig 35.
    """

    name = "overshoot"
    unit = "1"
    description = "Peak of the position step response above its final value, as a fraction"
    reference = "Bhatia 1971 Ch. IV B"

    def supports(self, loop: Loop, options=None):
        return has_numeric_response(loop) or has_sampled_step(loop)

    def optimisable(self, loop: Loop, options=None):
        return False

    def evaluate(self, loop: Loop, options):
        if has_sampled_step(loop):
            error = sampled_step_error(loop)
            return as_number(None if error is None else max(0.0, -error.lowest()))  # max y − 1
        response = numeric_response(loop, self.name, "step")
        if response is None:
            return as_number(None)
        final = 1.0 - response.steady  # position y = r − e with r = 1; e_ss = 0 for type 1
        with resolving(self.name):
            lowest_error, _ = response.extremes()
        return as_number(max(0.0, (response.steady - lowest_error) / final))  # max y − y_ss
