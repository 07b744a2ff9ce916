"""Closed-loop bandwidth (Bhatia 1971, Ch. IV A b)."""

from feedtune.expr import Crossing
from feedtune.frequency import first_crossing, log_grid, lowest_value, relative_grid
from feedtune.objectives.base import Metric
from feedtune.objectives.frequency_domain import has_frequency_band, normalised_gain_squared


class Bandwidth(Metric):
    """ω_b [rad/s]: the lowest ω where |T(jω)/T(0)| falls to 1/√2 (−3 dB), solved exactly.

    In the NLP ω_b is an auxiliary variable b with |T(jb)/T(0)|² = 1/2 and
    |T(jω)/T(0)|² ≥ 1/2 for ω < b (on a grid and at the refined minimum between grid
    points), so a dip below −3 dB anywhere under b is never overlooked.
    """

    name = "bandwidth"
    unit = "rad/s"
    description = "Lowest frequency where the normalised closed-loop gain falls to 0.707 (-3 dB)"
    reference = "Bhatia 1971 Ch. IV A (b)"

    def supports(self, loop, options=None):
        return has_frequency_band(loop)

    def evaluate(self, loop, options):
        gain = normalised_gain_squared(loop)
        band = loop.frequency_band
        omega = first_crossing(gain, band, 0.5, "bandwidth")
        count = len(log_grid(band))

        def condition(w):
            return gain(w) - 0.5

        return Crossing(condition, relative_grid(band),
                        lambda b: lowest_value(condition, (band[0], b), count, "bandwidth_dip"),
                        band, omega)
