"""Peak acceleration measured on the pulse train over a counting window (Tian et al. Fig 4)."""

from feedtune.lazy import np
from feedtune.loops.protocols import Loop
from feedtune.objectives.pulse.pulse_metric import PulseMetric, WindowOptions


class PeakMeasuredAcceleration(PulseMetric):
    """max |Δv_W|/(W T) [unit/s²], v_W = δ·(pulses in the last W periods)/(W T): what a
    counter of the emitted pulses reads, W = round(window·f) ≥ 1.

    References
    ----------
    Tian et al., §4, Fig 4 (velocity and acceleration of the produced pulse series).
    """

    name = "peak_measured_acceleration"
    unit = "m/s² (rad/s² on a rotary axis)"
    unit_template = "{x}/s²"  # {x}: the axis' position unit
    description = "Largest acceleration measured by counting pulses over a window"
    reference = "Tian et al. §4, Fig 4"
    Options = WindowOptions

    def evaluate(self, loop: Loop, options):
        r = loop.response
        return float(np.abs(r.measured_acceleration(r.window(options.window))).max(initial=0.0))
