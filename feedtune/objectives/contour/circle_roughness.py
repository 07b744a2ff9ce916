"""Peak-to-valley of the radial ripple in the exact circle test (measured Sato's Δm)."""

from feedtune.objectives.contour.circle_test import CircleTestMetric


class CircleRoughness(CircleTestMetric):
    """Peak-to-valley [m] of the radial deviation within one side (time T), worst side.

    The exact counterpart of Sato's surface roughness Δm (eq 10), which sums the ripple's
    harmonics without their phases (an upper bound). From the steady state of two
    identical axes following the interpolated polygon
    (:mod:`feedtune.objectives.contour.circle_test`). For a whole-number q = T/Δt_p the deviation
    repeats every side and this equals
    :class:`~feedtune.objectives.contour.circularity.Circularity`.
    Sampled loops behind a linear interpolator (``model: exact``) only; reported only.
    +∞ for an unstable loop.
    """

    name = "circle_roughness"
    description = ("Peak-to-valley of the radial ripple within one side of the steady "
                   "interpolated circle (exact circle test; reported only)")
    reference = "Sato et al. §3.2 (Δm, eq 10); exact periodic steady state"
    quantity = "roughness"
