"""Encoder pulses per sample at full speed, f_m/f_s (Koren eq 26)."""

from feedtune.loops.protocols import Loop
from feedtune.objectives.base import Metric


class EncoderRatio(Metric):
    """f_m/f_s = f_m·T [1]; Koren asks for ≥ 100 so that slow motion is still sensed (eq 26)."""

    name = "encoder_ratio"
    unit = "1"
    description = "Encoder frequency at V_m over sampling frequency, f_m/f_s"
    reference = "Koren 1979 eqs 1, 25, 26"

    def supports(self, loop: Loop, options=None):
        return loop.discrete and loop.drive.max_pulse_rate is not None

    def evaluate(self, loop: Loop, options):
        return loop.drive.max_pulse_rate * loop.period
