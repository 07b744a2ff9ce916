"""Closed-loop bandwidth (Bhatia 1971, Ch. IV A b)."""

from feedtune.expr import Crossing
from feedtune.loops.frequency import first_crossing, log_grid, lowest_value, relative_grid
from feedtune.loops.protocols import Loop
from feedtune.objectives.base import Metric
from feedtune.objectives.frequency.frequency_domain import (below_nyquist, has_frequency_band,
                                                            normalised_gain_squared)


class Bandwidth(Metric):
    """ω_b [rad/s]: the lowest ω where |T(jω)/T(0)| falls to 1/√2 (−3 dB), solved exactly.

    In the NLP ω_b is an auxiliary variable b with |T(jω)/T(0)|² ≥ 1/2 for ω ≤ b (on a
    grid, plus every refined dip the tuner finds below b; with a small margin so that no
    dip rests exactly on −3 dB), and |T(jb)/T(0)|² = 1/2 where b must be the crossing
    itself, so a dip below −3 dB anywhere under b is never overlooked. The condition is written (g − ½)/(g + ½) with g = |T/T(0)|²: the same
    sign, but bounded in [−1, 1], so it stays finite where a pole nears the jω axis.

    On a sampled loop T is the discrete loop's H(e^{jωT}); a loop whose gain stays above
    −3 dB up to the Nyquist frequency has ω_b = π/T (nothing above it is represented).
    """

    name = "bandwidth"
    unit = "rad/s"
    description = "Lowest frequency where the normalised closed-loop gain falls to 0.707 (-3 dB)"
    reference = "Bhatia 1971 Ch. IV A (b)"
    reformulated_as = Crossing

    def supports(self, loop: Loop, options=None):
        return has_frequency_band(loop)

    def evaluate(self, loop: Loop, options):
        gain = below_nyquist(loop, normalised_gain_squared(loop), 0.0)  # |H|² = 0 beyond π/T
        band = loop.frequency_band
        count = len(log_grid(band))

        def condition(w):
            g = gain(w)
            return (g - 0.5) / (g + 0.5)

        def lowest_minimum(b, margin):
            return lowest_value(lambda w: condition(w) - margin * (1 - w / b), (band[0], b),
                                count, "bandwidth_dip")

        return Crossing(condition, relative_grid(band), lowest_minimum, band,
                        locate=lambda: first_crossing(gain, band, 0.5, "bandwidth"))
