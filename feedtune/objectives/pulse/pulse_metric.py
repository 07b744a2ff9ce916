"""What the metrics of a reference-pulse loop share (Tian et al.; feedtune.loops.pulse_train).

They read only a loop's ``response`` (the exact pulse simulation) and apply to loops that
declare ``exact_only`` and carry one; every other metric declines such loops. They are
optimisable, but only by the derivative-free search (feedtune.tuner.search): on a loop
built from symbols the response raises TypeError.
"""

from __future__ import annotations

import math

from pydantic import Field

from feedtune.loops.protocols import Capability, Loop
from feedtune.objectives.base import Metric
from feedtune.schema.model import SpecModel


def is_pulse_loop(loop: Loop) -> bool:
    """The loop is an exact pulse simulation (``exact_only`` and a ``response``)."""
    return loop.offers(Capability.PULSE_SIMULATION)


def finite_or_inf(x: float) -> float:
    return float(x) if math.isfinite(x) else math.inf


class PulseMetric(Metric):
    """Base of the pulse-loop metrics; ``inputs`` lists the commands it is defined for."""

    inputs: tuple[str, ...] = ("step", "ramp", "sine")
    #: the unit with ``{x}`` for the axis' position unit, or None: ``unit`` as it is
    unit_template: str | None = None

    def unit_of(self, options, position_unit: str = "m") -> str:
        template = self.unit_template
        return template.format(x=position_unit) if template else self.unit

    def supports(self, loop: Loop, options=None) -> bool:
        return is_pulse_loop(loop) and loop.input_kind in self.inputs


class WindowOptions(SpecModel):
    """Window of the pulse counter that measures velocity."""

    window: float = Field(1e-3, gt=0, description="Counting window [s] (at least one period)")


class StepBandOptions(SpecModel):
    """Band around the target."""

    band: float = Field(0.0, ge=0, description="Half-width of the settling band [pulse]; 0: "
                                               "the counter on the target exactly")
