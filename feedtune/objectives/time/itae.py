"""Integral of time-weighted absolute error after a position step or ramp (Bhatia Ch. IV B)."""

from feedtune.objectives.time.step_error import StepErrorMetric


class Itae(StepErrorMetric):
    """ITAE = ∫t|e(t)|dt [m·s²] after a unit (1 m or 1 rad) position step.

    Koren's loops: exact between samples and smooth in the tunables. Loops given by
    polynomials: exact between the zero crossings of the response, reported only. With
    ``input`` ramp (loops given by polynomials only) the integrand is t|e(t) − e_ss|,
    e_ss = 1/C_v.

    References
    ----------
    S. Bhatia, "Feed drive design for NC machine tools", 1971, Ch. IV B (E = ∫t|e(t)|dt).
    """

    name = "itae"
    unit = "m·s² (time absolute) or m·rad² (time natural); rad for m on a rotary axis"
    description = ("Integral of t·|position error| after a unit position step, or of "
                   "t·|e − e_ss| after a unit ramp")
    reference = "Bhatia 1971 Ch. IV B"
    time_power = 2
    units = ('{x}·s²', '{x}·rad²')  # {x}: the axis' position unit
