"""Overshoot of a pulse generator's step response, in pulses (Tian et al. §2)."""

from feedtune.loops.protocols import Loop
from feedtune.objectives.pulse.pulse_metric import PulseMetric


class PulseOvershoot(PulseMetric):
    """max_i (n_i − n_target)·sign(step) [pulse], 0 if the counter never passes the target.

    References
    ----------
    Tian et al., §2: the error limit is there because "surplus error accumulation may cause
    overshoot".
    """

    name = "pulse_overshoot"
    unit = "pulse"
    description = "Pulses the counter passes the step target by"
    reference = "Tian et al. §2"
    inputs = ("step",)

    def evaluate(self, loop: Loop, options):
        r = loop.response
        target = int(r.reference[-1]) if len(r.reference) else 0
        sign = 1 if target >= 0 else -1
        return float(max(0, int(((r.counter - target) * sign).max(initial=0))))
