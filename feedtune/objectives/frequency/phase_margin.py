"""Phase margin of the open loop (Bhatia 1971, Ch. IV F; 73° uncompensated)."""

import math

from feedtune.lazy import ca
from feedtune.loops.frequency import value_at
from feedtune.loops.protocols import Loop
from feedtune.objectives.base import Metric
from feedtune.objectives.frequency.frequency_domain import as_number, gain_crossover, has_open_loop


class PhaseMargin(Metric):
    """180° + arg L(jω_c) [deg] at the lowest gain crossover ω_c (|L| = 1); on a sampled
    loop L(e^{jωT}), hold and computation delay included."""

    name = "phase_margin"
    unit = "deg"
    description = "180 deg plus the open-loop phase where |L| = 1 [deg]"
    reference = "Bhatia 1971 Ch. IV F (phase margin 73° of the uncompensated loop)"

    def supports(self, loop: Loop, options=None):
        return has_open_loop(loop)

    def evaluate(self, loop: Loop, options):
        omega = as_number(gain_crossover(loop))
        return value_at("phase_margin", _phase_margin_at, loop, omega)


def _phase_margin_at(loop: Loop):
    """ω ↦ 180° + arg L(jω) [deg] (an :class:`OfLoop` factory)."""
    def margin(omega):
        re, im = loop.open_loop_response(omega)
        return ca.atan2(-im, -re) * (180 / math.pi)

    return margin
