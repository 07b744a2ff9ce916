"""Margin to the motor's torque–frequency characteristic (Tian et al. §3)."""

from feedtune.loops.protocols import Loop
from feedtune.objectives.pulse.pulse_metric import PulseMetric, is_pulse_loop


class MotorAccelerationMargin(PulseMetric):
    """min(1 − |a_i|/a_motor(rate_i), 1 − rate_max/rate_motor) [1]: ≥ 0 iff the commanded
    acceleration stays under the motor's characteristic at the pulse rate of every period
    and the pulse rate under the motor's highest; as a constraint: ``min: 0``.

    References
    ----------
    Tian et al., §3 (torque–frequency characteristic; k set so that δf²/k is the motor's
    acceleration) and §4 (SGME-02A: 140 kHz, 140 krad/s²).
    """

    name = "motor_acceleration_margin"
    unit = "1"
    description = "Relative margin of the commanded acceleration and pulse rate to the motor's characteristic"
    reference = "Tian et al. §3"

    def supports(self, loop: Loop, options=None) -> bool:
        return is_pulse_loop(loop) and loop.motor is not None

    def evaluate(self, loop: Loop, options):
        return loop.motor.margin(loop.response)
