"""Options, time normalisation and numeric responses shared by the time-domain metrics.

Two ways to a step-error integral exist:

* Koren's loops (:class:`~feedtune.loops.loop.ContinuousLoop` of order two,
  :class:`~feedtune.loops.loop.SampledLoop`) give exact symbolic IAE/ISE/ITAE for a position step
  (``loop.step_error_integrals``): smooth in the tunables, so they can be optimised;
* loops given by polynomials (:class:`~feedtune.loops.loop.TransferLoop`, Bhatia's drives) give
  their transfer functions as numbers (``loop.numeric_transfer``); the response is
  evaluated exactly by :mod:`feedtune.loops.timeresponse` on the tuned design. Such a metric is
  reported only: it cannot be an objective term or a constraint (``optimisable`` False).
"""

from __future__ import annotations

import contextlib
import math
from typing import Literal

from pydantic import Field

from feedtune.expr import is_symbolic
from feedtune.lazy import ca
from feedtune.loops import timeresponse
from feedtune.loops.loop import HorizonError
from feedtune.loops.protocols import Capability, Loop
from feedtune.objectives.base import Metric
from feedtune.schema.model import SpecModel

InputKind = Literal["step", "ramp"]

INPUT_DESCRIPTION = (
    "step: error after a unit position step (1 m or 1 rad); ramp: after a unit ramp (1 m/s "
    "or 1 rad/s), integrated on e(t) − e_ss, e_ss = 1/C_v the steady following error of a "
    "type-1 loop (the plain ∫|e| of a ramp diverges). Ramp needs a loop given by "
    "polynomials (reported only)")


class StepErrorOptions(SpecModel):
    """Error after a unit position step or ramp, integrated until the loop has settled."""

    time: Literal["absolute", "natural"] = Field(
        "absolute",
        description="absolute: integrate over t [s]; natural: over ω_n·t [rad], Koren's "
                    "convention for Fig 6 and Kτ = 0.567 (needs a second-order loop)")
    input: InputKind = Field("step", description=INPUT_DESCRIPTION)


def has_numeric_response(loop: Loop) -> bool:
    """The loop gives its transfer functions as numbers (a loop given by polynomials)."""
    return loop.offers(Capability.NUMERIC_TRANSFER)


def has_exact_step(loop: Loop, options: StepErrorOptions) -> bool:
    """Koren's exact symbolic step integrals apply (step input, a loop that has them)."""
    return options.input == "step" and loop.offers(Capability.EXACT_STEP_ERROR)


def supports_step_error(loop: Loop, options: StepErrorOptions) -> bool:
    """Exact symbolic integrals exist (with ω_n when time is natural), or the loop gives
    numeric transfer functions (absolute time only)."""
    if has_exact_step(loop, options):
        return options.time == "absolute" or loop.order == 2
    return has_numeric_response(loop) and options.time == "absolute"


def optimisable_step_error(loop: Loop, options: StepErrorOptions) -> bool:
    """Only the exact symbolic integrals can enter the NLP."""
    return supports_step_error(loop, options) and has_exact_step(loop, options)


def time_weight(loop: Loop, options: StepErrorOptions, power: int):
    """ω_n^power when time is natural, else 1: ∫t^k|e|dt in units of (ω_n t)."""
    if options.time == "absolute":
        return 1.0
    return loop.natural_frequency() ** power


def step_error_unit(options: StepErrorOptions, absolute: str, natural: str) -> str:
    """The unit that goes with the chosen time axis."""
    return absolute if options.time == "absolute" else natural


# -- numeric responses of loops given by polynomials ---------------------------------------

def numeric_transfer(loop: Loop, metric_name: str, output: str, input: str):
    """(numerator, denominator) float arrays of ``loop``, or TypeError for a symbolic loop."""
    polynomials = list(loop.open_numerator) + list(loop.open_denominator)
    if input == "load" and loop.load_numerator is not None:
        polynomials += list(loop.load_numerator)
    if is_symbolic(*polynomials):
        raise TypeError(
            f"metric {metric_name!r} is evaluated numerically from the time response of this "
            "loop and cannot be an objective term or a constraint (it is reported on the "
            "tuned design only); evaluate it on a loop built from numbers")
    return loop.numeric_transfer(output, input)


def numeric_response(loop: Loop, metric_name: str, source: str):
    """The exact response of a loop of numbers; ``source`` is step, ramp or load.

    step/ramp: position error after a unit reference step/ramp; load: position after a
    1 N·m load-torque step. Returns None for an unstable loop (the metric is then +∞).

    Raises
    ------
    TypeError
        For a symbolic loop (inside the NLP).
    HorizonError
        When the response lives too long to be resolved (a nearly undamped loop).
    """
    if source == "load":
        num, den = numeric_transfer(loop, metric_name, "position", "load")
    else:
        num, den = numeric_transfer(loop, metric_name, "error", "reference")
    try:
        if source == "load":
            return timeresponse.load_response(num, den)
        return timeresponse.reference_error(num, den, source)
    except timeresponse.UnstableResponseError:
        return None
    except timeresponse.ResponseTooLongError as exc:
        raise HorizonError(f"{metric_name}: {exc}") from None


@contextlib.contextmanager
def resolving(metric_name: str):
    """Reading a response's crossings or extrema inside this block raises
    :class:`~feedtune.loops.loop.HorizonError` (reported null) for a response too long to resolve
    (a lightly damped mode beside a slow one): a response computes them when first read,
    after :func:`numeric_response` has returned it."""
    try:
        yield
    except timeresponse.ResponseTooLongError as exc:
        raise HorizonError(f"{metric_name}: {exc}") from None


def as_number(value: float):
    """A metric value for a loop of numbers, as CasADi takes it (+∞ for an unstable loop)."""
    return ca.DM(value if value is not None else math.inf)


def numeric_error_integral(loop: Loop, options: StepErrorOptions, metric_name: str, which: str):
    """IAE, ISE or ITAE (``which``) of e(t) − e_ss after a unit step or ramp, as a ca.DM.

    e_ss = 0 after a step for a type-1 loop; 1/C_v after a ramp.
    """
    response = numeric_response(loop, metric_name, options.input)
    if response is None:
        return as_number(None)
    with resolving(metric_name):
        return as_number(getattr(response.transient, which))


class StepErrorMetric(Metric):
    """Base of IAE, ISE and ITAE: the integral named by ``name`` of the error response.

    Subclasses set ``time_power`` (the power of ω_n that natural time brings) and
    ``units`` (absolute, natural).
    """

    Options = StepErrorOptions
    time_power: int
    units: tuple[str, str]

    def unit_of(self, options, position_unit="m"):
        return step_error_unit(options, *self.units).format(x=position_unit)

    def supports(self, loop: Loop, options=StepErrorOptions()):
        return supports_step_error(loop, options)

    def optimisable(self, loop: Loop, options=StepErrorOptions()):
        return optimisable_step_error(loop, options)

    def evaluate(self, loop: Loop, options):
        if not has_exact_step(loop, options):
            return numeric_error_integral(loop, options, self.name, self.name)
        return time_weight(loop, options, self.time_power) * getattr(loop.step_error_integrals, self.name)
