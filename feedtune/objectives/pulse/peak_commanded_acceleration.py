"""Peak commanded acceleration of a pulse generator (Tian et al. eqs 1–2)."""

from feedtune.lazy import np
from feedtune.loops.protocols import Loop
from feedtune.objectives.pulse.pulse_metric import PulseMetric


class PeakCommandedAcceleration(PulseMetric):
    """max_i |v_i − v_{i−1}|·f [unit/s²], v_i = δ f e_i/value the commanded velocity.

    δ f² without the acceleration law (Tian eq 1), at most δ f²/k with it (eq 2).

    References
    ----------
    Tian et al., §3, eqs 1–2, Fig 3.
    """

    name = "peak_commanded_acceleration"
    unit = "m/s² (rad/s² on a rotary axis)"
    unit_template = "{x}/s²"  # {x}: the axis' position unit
    description = "Largest change of the commanded velocity per period, per second"
    reference = "Tian et al. eqs 1–2"

    def evaluate(self, loop: Loop, options):
        return float(np.abs(loop.response.commanded_acceleration).max(initial=0.0))
