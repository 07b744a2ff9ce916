"""Largest commanded velocity of a pulse generator (Tian et al. §3, Koren eq 1)."""

from feedtune.lazy import np
from feedtune.loops.protocols import Loop
from feedtune.objectives.pulse.pulse_metric import PulseMetric


class PulseMaxVelocity(PulseMetric):
    """max_i |δ f e_i/value| [unit/s]; at most v_max = δ f (one pulse per period).

    References
    ----------
    Tian et al., §3; Koren 1979 eq 1 (f_m = V_m/BLU).
    """

    name = "pulse_max_velocity"
    unit = "m/s (rad/s on a rotary axis)"
    unit_template = "{x}/s"  # {x}: the axis' position unit
    description = "Largest commanded velocity (pulse rate times the pulse equivalent)"
    reference = "Tian et al. §3; Koren 1979 eq 1"

    def evaluate(self, loop: Loop, options):
        return float(np.abs(loop.response.commanded_velocity).max(initial=0.0))
