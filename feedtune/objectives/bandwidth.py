"""Closed-loop bandwidth (Bhatia 1971, Ch. IV A b)."""

from feedtune.frequency import first_crossing
from feedtune.objectives.base import Metric
from feedtune.objectives.frequency_domain import has_frequency_band, normalised_gain_squared


class Bandwidth(Metric):
    """ω_b [rad/s]: the lowest ω where |T(jω)/T(0)| falls to 1/√2 (−3 dB), solved exactly."""

    name = "bandwidth"
    unit = "rad/s"
    description = "Lowest frequency where the normalised closed-loop gain falls to 0.707 (-3 dB)"
    reference = "Bhatia 1971 Ch. IV A (b)"

    def supports(self, loop, options=None):
        return has_frequency_band(loop)

    def evaluate(self, loop, options):
        omega, _ = first_crossing(normalised_gain_squared(loop), loop.frequency_band, 0.5, "bandwidth")
        return omega
