"""Circularity of the exact circle test, max − min radial deviation (ISO 230-4)."""

from feedtune.objectives import circle_test
from feedtune.objectives.base import Metric
from feedtune.objectives.circle import CircleOptions


class Circularity(Metric):
    """max |y| − min |y| [m] over the whole steady circle (ISO 230-4 circular deviation G).

    ISO 230-4 takes the radial range about the least-squares centre; the steady state of
    two identical axes is rotation-symmetric about the commanded centre, which is used.
    From :mod:`feedtune.objectives.circle_test`. Sampled loops behind a linear
    interpolator (``model: exact``) only; reported only. +∞ for an unstable loop.
    """

    name = "circularity"
    unit = "m"
    description = ("Max − min radial deviation over the steady interpolated circle, as "
                   "ISO 230-4 (exact circle test; reported only)")
    reference = "ISO 230-4; Sato et al. §3; exact periodic steady state"
    Options = CircleOptions

    def supports(self, loop, options=None):
        return circle_test.supports(loop)

    def optimisable(self, loop, options=None):
        return False

    def evaluate(self, loop, options):
        return circle_test.circle_value(loop, options, "circularity")
