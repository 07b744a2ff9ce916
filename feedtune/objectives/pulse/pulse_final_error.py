"""Final position error of a pulse generator (Tian et al. §4; Koren's following error)."""

from feedtune.loops.protocols import Loop
from feedtune.objectives.pulse.pulse_metric import PulseMetric


class PulseFinalError(PulseMetric):
    """|r(t_end) − δ·n(t_end)| [unit] at the end of the simulation: after a step the
    quantisation of the target (≤ δ/2) once at rest; after a ramp below the maximum rate
    the constant lag v·value/v_max (to a pulse).

    References
    ----------
    Tian et al., §4 ("high precision in positioning"); Koren 1979, Reference-Pulse technique
    (one pulse is one BLU).
    """

    name = "pulse_final_error"
    unit = "m (rad on a rotary axis)"
    unit_template = "{x}"  # {x}: the axis' position unit
    description = "Command minus actual position at the end of the simulation, absolute"
    reference = "Tian et al. §4"
    inputs = ("step", "ramp")

    def evaluate(self, loop: Loop, options):
        r = loop.response
        if loop.input_kind == "step":
            return abs(loop.command.amplitude - float(r.position[-1]))
        t_end = float(r.time[-1])
        return abs(float(loop.command.position(t_end)) - float(r.position[-1]))
