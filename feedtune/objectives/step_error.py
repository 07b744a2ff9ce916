"""Options and time normalisation shared by the step-error integrals (IAE, ISE, ITAE)."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from feedtune.model import SpecModel


class StepErrorOptions(SpecModel):
    """Error after a 1 m position step, integrated to the loop's settling horizon."""

    time: Literal["absolute", "natural"] = Field(
        "absolute",
        description="absolute: integrate over t [s]; natural: over ω_n·t [rad], Koren's "
                    "convention for Fig 6 and Kτ = 0.567 (needs a second-order loop)")


def supports_step_error(loop, options: StepErrorOptions) -> bool:
    """Exact integrals exist, and ω_n too when time is natural."""
    if not loop.has_exact_step_error:
        return False
    return options.time == "absolute" or loop.order == 2


def time_weight(loop, options: StepErrorOptions, power: int):
    """ω_n^power when time is natural, else 1: ∫t^k|e|dt in units of (ω_n t)."""
    if options.time == "absolute":
        return 1.0
    return loop.natural_frequency() ** power


def step_error_unit(options: StepErrorOptions, absolute: str, natural: str) -> str:
    """The unit that goes with the chosen time axis."""
    return absolute if options.time == "absolute" else natural
