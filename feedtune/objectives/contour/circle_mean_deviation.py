"""Mean radial deviation of the exact circle test (the measured counterpart of Sato's Δr)."""

from feedtune.objectives.contour.circle_test import CircleTestMetric


class CircleMeanDeviation(CircleTestMetric):
    """mean(|y|) − r [m] of the steady circle, signed: negative when the circle shrinks.

    The time mean of the radial deviation over the steady state of two identical axes
    following the interpolated polygon (:mod:`feedtune.objectives.contour.circle_test`: exact
    periodic steady state of the sampled loop, continuous between samples). Its negative
    is the measured counterpart of Sato's decrease in radius Δr (eq 7), which takes the
    radius of the polygon's area (eq 3) times |G(jω)|. Sampled loops behind a linear
    interpolator (``model: exact``) only; reported only, never optimised (numeric, and
    not smooth in q = T/Δt_p). +∞ for an unstable loop.
    """

    name = "circle_mean_deviation"
    description = ("Mean radial deviation of the steady interpolated circle, mean |y| − r "
                   "(exact circle test; reported only)")
    reference = "Sato et al. §3 (Δr, eq 7); exact periodic steady state"
    quantity = "mean_deviation"
