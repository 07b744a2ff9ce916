"""Integral of absolute error after a position step or ramp (Koren eq 20; Bhatia Ch. IV B)."""

from feedtune.objectives.time.step_error import StepErrorMetric


class Iae(StepErrorMetric):
    """IAE = ∫|e(t)|dt [m·s] after a unit (1 m or 1 rad) position step.

    Koren's loops: exact between samples and smooth in the tunables (Koren eq 20). Loops
    given by polynomials (Bhatia's drives): evaluated numerically from the exact response
    (:mod:`feedtune.loops.timeresponse`), reported only. With ``input`` ramp (1 m/s or 1 rad/s,
    loops given by polynomials only) the integrand is |e(t) − e_ss|, e_ss = 1/C_v the steady
    following error, because ∫|e| of a type-1 loop's ramp error diverges.

    References
    ----------
    Y. Koren, "Design of computer control for manufacturing systems", 1979, eq 20.
    S. Bhatia, "Feed drive design for NC machine tools", 1971, Ch. IV B (E = ∫|e(t)|dt).
    """

    name = "iae"
    unit = "m·s (time absolute) or m·rad (time natural); rad for m on a rotary axis"
    description = ("Integral of |position error| after a unit position step, or of "
                   "|e − e_ss| after a unit ramp")
    reference = "Koren 1979 eq 20; Bhatia 1971 Ch. IV B"
    time_power = 1
    units = ('{x}·s', '{x}·rad')  # {x}: the axis' position unit
