"""Fraction of the feedback counter's range used per sample at full speed."""

from feedtune.loops.protocols import Loop
from feedtune.objectives.base import Metric


class CounterUtilisation(Metric):
    """f_m·T / 2^(bits−1) [1]; above 1 the counter overflows between two readings.

    Koren's 8-bit counter (one sign bit) reads up to 2⁷ = 128 pulses per sample.
    """

    name = "counter_utilisation"
    unit = "1"
    description = "Pulses per sample at V_m over the counter's capacity 2^(bits−1)"
    reference = "Koren 1979, discussion after eq 26"

    def supports(self, loop: Loop, options=None):
        d = loop.drive
        return loop.discrete and d.max_pulse_rate is not None and d.counter_bits is not None

    def evaluate(self, loop: Loop, options):
        d = loop.drive
        return d.max_pulse_rate * loop.period / 2 ** (d.counter_bits - 1)
