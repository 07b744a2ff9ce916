"""Settling time of the position error after a unit step or ramp (Bhatia 1971 Ch. IV B)."""

from pydantic import Field

from feedtune.loops.protocols import Loop
from feedtune.loops.timeresponse import has_sampled_step, sampled_step_error
from feedtune.objectives.base import Metric
from feedtune.objectives.time.step_error import (InputKind, as_number, has_numeric_response,
                                                 numeric_response, resolving)
from feedtune.schema.model import SpecModel


class SettlingTimeOptions(SpecModel):
    """Band and input of the settling time."""

    band: float = Field(
        0.02, gt=0, lt=1,
        description="Half-width of the settling band [1]: a fraction of the step size (1 m "
                    "or 1 rad) for input step, of the steady following error e_ss = 1/C_v "
                    "for input ramp")
    input: InputKind = Field(
        "step", description="step: error after a unit position step (1 m or 1 rad); ramp: "
                            "after a unit ramp (1 m/s or 1 rad/s), settling towards the steady "
                            "following error e_ss = 1/C_v")


class SettlingTime(Metric):
    """T_s [s]: the time after which |e(t) − e_ss| stays within the band for ever.

    After a unit step the band is ``band`` × 1 (m or rad) around e_ss = 0; after a unit
    ramp it is ``band`` × e_ss around the steady following error e_ss = 1/C_v (a band on
    the ramp's size would be wider than the whole error of a stiff loop; a loop that follows
the ramp with e_ss = 0 gets the step's band). 0 when the error
    never leaves the band. Evaluated exactly (:mod:`feedtune.loops.timeresponse`: the last
    crossing of the band edge, refined by Brent's method) on loops given by polynomials,
    and after a step on a sampled-data loop in continuous time, between samples too
    (:class:`feedtune.loops.timeresponse.SampledStepError`); reported only, never optimised. +∞
    for an unstable loop.

    References
    ----------
    S. Bhatia, "Feed drive design for NC machine tools", 1971, Ch. IV B (settling time
    T_S) and Ch. IV F, Figs 35, 36 (transients die out in ≈0.35 s at K'_p = 80).
    """

    name = "settling_time"
    unit = "s"
    description = ("Time after which the position error stays within a band around its "
                   "steady value after a unit step or ramp")
    reference = "Bhatia 1971 Ch. IV B"
    Options = SettlingTimeOptions

    def supports(self, loop: Loop, options=None):
        if has_sampled_step(loop):
            return options is None or options.input == "step"
        return has_numeric_response(loop)

    def optimisable(self, loop: Loop, options=None):
        return False

    def evaluate(self, loop: Loop, options):
        if has_sampled_step(loop):
            error = sampled_step_error(loop)
            return as_number(None if error is None else error.last_exit(options.band))
        response = numeric_response(loop, self.name, options.input)
        if response is None:
            return as_number(None)
        # a ramp followed without steady error (a loop of type 2, or full velocity
        # feed-forward) has no e_ss to scale the band: it is then on 1 m (1 rad), as a step's
        size = 1.0 if options.input == "step" or response.steady == 0 else abs(response.steady)
        with resolving(self.name):
            return as_number(response.transient.last_exit(options.band * size))
