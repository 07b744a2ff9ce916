"""Rejection of a load-torque step T_L (Bhatia 1971 Ch. IV, Fig 16, App. A2)."""

from typing import Literal

from pydantic import Field

from feedtune.loops.protocols import Capability, Loop
from feedtune.objectives.base import Metric
from feedtune.objectives.time.step_error import (as_number, has_numeric_response, numeric_response,
                                                 resolving)
from feedtune.schema.model import SpecModel


class LoadRejectionOptions(SpecModel):
    """Which measure of the position error after a load step."""

    measure: Literal["peak", "iae"] = Field(
        "peak",
        description="peak: max |position error| [rad per N·m]; iae: ∫|e(t) − e_ss| dt "
                    "[rad·s per N·m], e_ss the static load error (a type-1 loop with the "
                    "integration after the load keeps one, so ∫|e| would diverge)")


class LoadRejection(Metric):
    """Position error after a 1 N·m load-torque step with the reference held still.

    ``measure`` peak: max_t |e(t)| [rad/(N·m)], the static load error e_ss included (the
    supremum when the error creeps up to it). ``measure`` iae: ∫|e(t) − e_ss| dt
    [rad·s/(N·m)], exact between zero crossings. Defined where the loop has a load path
    (``loop.load_numerator``); evaluated exactly (:mod:`feedtune.loops.timeresponse`), reported
    only, never optimised. +∞ for an unstable loop.

    References
    ----------
    S. Bhatia, "Feed drive design for NC machine tools", 1971, Ch. IV (T_L studied during
    simulation; Fig 16), App. A2 (load-torque term of the valve-controlled motor).
    """

    name = "load_rejection"
    unit = "rad/(N·m) (peak) or rad·s/(N·m) (iae)"
    description = "Peak or IAE of the position error after a 1 N·m load-torque step"
    reference = "Bhatia 1971 Ch. IV, App. A2"
    Options = LoadRejectionOptions

    def unit_of(self, options, position_unit="rad"):  # load torque: rotary axes so far
        per_torque = f"{position_unit}/(N·m)"
        return per_torque if options.measure == "peak" else f"{position_unit}·s/(N·m)"

    def supports(self, loop: Loop, options=None):
        return has_numeric_response(loop) and loop.offers(Capability.LOAD_INPUT)

    def optimisable(self, loop: Loop, options=None):
        return False

    def evaluate(self, loop: Loop, options):
        response = numeric_response(loop, self.name, "load")
        if response is None:
            return as_number(None)
        with resolving(self.name):
            if options.measure == "iae":
                return as_number(response.transient.iae)
            low, high = response.extremes()
        return as_number(max(abs(low), abs(high)))
