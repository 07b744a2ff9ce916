"""Settling time of a pulse generator's step response (Tian et al. §4, Fig 4)."""

from feedtune.lazy import np
from feedtune.loops.protocols import Loop
from feedtune.objectives.pulse.pulse_metric import PulseMetric, StepBandOptions


class PulseSettlingTime(PulseMetric):
    """T_s [s]: the end of the last period whose counter lies outside ``band`` pulses of the
    target (0 when it never does); +∞ unless the simulation proved the axis at rest (step
    done, e = 0: no pulse can follow).

    References
    ----------
    Tian et al., §4, Fig 4 ("high precision in positioning").
    """

    name = "pulse_settling_time"
    unit = "s"
    description = "Time after which the pulse counter stays within a band of the step target"
    reference = "Tian et al. §4, Fig 4"
    inputs = ("step",)
    Options = StepBandOptions

    def evaluate(self, loop: Loop, options):
        r = loop.response
        if not r.at_rest:
            return float("inf")
        outside = np.nonzero(np.abs(r.counter - r.reference[-1]) > options.band)[0]
        if not len(outside):
            return 0.0
        # at rest means the last counter is on target, so a period follows the last outside
        return r.end_of(int(outside[-1]) + 1)
