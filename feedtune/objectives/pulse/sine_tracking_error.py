"""Tracking error of a pulse generator following a sine (Tian et al. §4, Fig 5)."""

import math

from feedtune.lazy import np
from feedtune.loops.protocols import Loop
from feedtune.objectives.pulse.pulse_metric import PulseMetric


class SineTrackingError(PulseMetric):
    """max |A sin ωt − δ·n(t)| [unit] over the last sine period simulated (the start-up
    transient excluded), t at the end of each period against the counter then.

    References
    ----------
    Tian et al., §4, Fig 5 (sin response).
    """

    name = "sine_tracking_error"
    unit = "m (rad on a rotary axis)"
    unit_template = "{x}"  # {x}: the axis' position unit
    description = "Largest command minus position over the last period of a sine command"
    reference = "Tian et al. §4, Fig 5"
    inputs = ("sine",)

    def evaluate(self, loop: Loop, options):
        r = loop.response
        t = r.time
        start = t[-1] - 2 * math.pi / loop.command.angular_frequency
        last = t >= start
        error = loop.command.position(t[last]) - r.position[last]
        return float(np.abs(error).max(initial=0.0))
