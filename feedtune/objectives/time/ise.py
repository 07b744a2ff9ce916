"""Integral of squared error after a position step or ramp (Bhatia Ch. IV B)."""

from feedtune.objectives.time.step_error import StepErrorMetric


class Ise(StepErrorMetric):
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
    time_power = 1
    units = ('{x}²·s', '{x}²·rad')  # {x}: the axis' position unit
