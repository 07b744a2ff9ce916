"""Circularity of the exact circle test, max − min radial deviation (ISO 230-4)."""

from feedtune.objectives.contour.circle_test import CircleTestMetric


class Circularity(CircleTestMetric):
    """max |y| − min |y| [m] over the whole steady circle (ISO 230-4 circular deviation G).

    ISO 230-4 takes the radial range about the least-squares centre; the steady state of
    two identical axes is rotation-symmetric about the commanded centre, which is used.
    From :mod:`feedtune.objectives.contour.circle_test`. Sampled loops behind a linear
    interpolator (``model: exact``) only; reported only. +∞ for an unstable loop.
    """

    name = "circularity"
    description = ("Max − min radial deviation over the steady interpolated circle, as "
                   "ISO 230-4 (exact circle test; reported only)")
    reference = "ISO 230-4; Sato et al. §3; exact periodic steady state"
    quantity = "circularity"
