"""Rise time of a pulse generator's step response (Tian et al. §4, Fig 4)."""

from feedtune.lazy import np
from feedtune.loops.protocols import Loop
from feedtune.objectives.pulse.pulse_metric import PulseMetric


class PulseRiseTime(PulseMetric):
    """t_90 − t_10 [s]: the first times the position δ·n reaches 10 % and 90 % of the step.

    References
    ----------
    Tian et al., §4, Fig 4 (step of 10 rad).
    """

    name = "pulse_rise_time"
    unit = "s"
    description = "10–90 % rise time of the pulse generator's step response"
    reference = "Tian et al. §4, Fig 4"
    inputs = ("step",)

    def evaluate(self, loop: Loop, options):
        r = loop.response
        target = r.reference[-1] if len(r.reference) else 0
        if target == 0:
            return 0.0
        progress = r.counter / target
        t = r.time
        low, high = np.nonzero(progress >= 0.1)[0], np.nonzero(progress >= 0.9)[0]
        if not len(high):
            return float("inf")
        return float(t[high[0]] - t[low[0]])
