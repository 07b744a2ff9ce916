"""Koren's closed-form radial error: eq 28–29 (sampled data) or eq 37 (reference pulse)."""

from feedtune.lazy import ca
from feedtune.loops.protocols import Loop
from feedtune.objectives.base import Magnitude, Metric
from feedtune.objectives.contour.circle import CircleOptions


def koren_l(gain, period, tau):
    """L = (Kτ(T/τ + 2) − 1)/(KT)² (Koren eq 29)."""
    return (gain * tau * (period / tau + 2) - 1) / (gain * period) ** 2


class RadialErrorKoren(Metric):
    """|e_r| [m] by Koren's formulas, for a first-order drive.

    Sampled data: e_r/r = (L/2)(ωT)² (eq 28 without its N(ωT)⁴ term, whose N the paper
    does not give). Reference pulse: eq 37, exact for the continuous loop.
    """

    name = "radial_error_koren"
    unit = "m"
    description = "Radial error on a circle by Koren's eq 28/29 (sampled) or eq 37 (continuous)"
    reference = "Koren 1979 eqs 28, 29, 37"
    Options = CircleOptions
    lifted_options = ("radius", "feed")  # ω = feed/radius: arithmetic only

    def supports(self, loop: Loop, options=None):
        # K/(s(1+sτ)) closed continuously or sampled without delay: order two (not a Padé loop)
        return loop.drive.time_constant is not None and loop.order == 2

    def evaluate(self, loop: Loop, options):
        omega = options.feed / options.radius
        k, tau = loop.velocity_constant, loop.drive.time_constant
        if loop.discrete:
            t = loop.period
            return Magnitude(options.radius * koren_l(k, t, tau) / 2 * (omega * t) ** 2)
        wn = ca.sqrt(k / tau)  # eq 10
        zeta = 1 / (2 * ca.sqrt(k * tau))  # eq 9
        ratio = omega / wn
        return Magnitude(options.radius * (
            1 - 1 / ca.sqrt(1 + (2 * zeta * ratio) ** 2 - 2 * ratio**2 + ratio**4)))
