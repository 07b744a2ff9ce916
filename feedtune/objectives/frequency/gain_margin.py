"""Gain margin of the open loop (Bhatia 1971, Ch. IV F; ≈ 1.2 uncompensated)."""

from feedtune.expr import Unbounded
from feedtune.lazy import ca
from feedtune.loops.frequency import crossing_if_any, replayed_at
from feedtune.loops.protocols import Loop
from feedtune.loops.twin import OfLoop
from feedtune.objectives.base import Metric
from feedtune.objectives.frequency.frequency_domain import (as_number, has_open_loop,
                                                            phase_crossover_indicator)


class GainMargin(Metric):
    """1/|L(jω_180)| [1] at the lowest phase crossover ω_180 (arg L = −180°); +∞ where the
    phase never reaches −180° in the loop's band (Koren's K/(s(1 + sτ)), any loop whose
    Nyquist plot never meets the negative real axis), as python-control's
    ``stability_margins`` gives it.

    A sampled loop's L(e^{jωT}) is real at the Nyquist frequency: when it is negative there
    and the phase has not reached −180° before, ω_180 = π/T (a ZOH loop without delay);
    when it is positive there, the phase has not crossed −180° below π/T and the margin is
    +∞. Where the lowest ω with Im L = 0 has Re L ≥ 0 (the positive real axis, not a phase
    crossover) the margin is +∞ too. The value is an :class:`~feedtune.expr.Unbounded`:
    the NLP reads 1/|L| at the band's top (where the crossing is looked for last) where
    there is no crossover, so a bound from below holds there and one from above does not.
    """

    name = "gain_margin"
    unit = "1"
    description = ("Factor by which the open-loop gain may grow before instability (ratio, "
                   "not dB); +inf without a phase crossover")
    reference = "Bhatia 1971 Ch. IV F (gain margin 1.2 of the uncompensated loop)"
    infinite_when = "no phase crossover: the open-loop phase never reaches −180°"

    def supports(self, loop: Loop, options=None):
        return has_open_loop(loop)

    def evaluate(self, loop: Loop, options):
        omega, found = crossing_if_any(phase_crossover_indicator(loop), loop.frequency_band,
                                       0.0, "phase_crossover")
        omega = as_number(omega)
        inverse = replayed_at("gain_margin", OfLoop(_inverse_gain, loop), omega)
        real = replayed_at("gain_margin_real", OfLoop(_real_part, loop), omega)
        if inverse is not None and real is not None:  # a loop of numbers: no graph built
            return Unbounded(ca.DM(inverse), found * (ca.DM(real) < 0))  # numbers: DM
        re, im = loop.open_loop_response(omega)
        return Unbounded(_inverse(re, im), found * (re < 0))


def _inverse(re, im):
    """1/|L| [1] of L = re + j·im."""
    return 1 / ca.sqrt(re**2 + im**2)


def _inverse_gain(loop: Loop):
    """ω ↦ 1/|L(jω)| [1] (an :class:`OfLoop` factory)."""
    return lambda omega: _inverse(*loop.open_loop_response(omega))


def _real_part(loop: Loop):
    """ω ↦ Re L(jω) [1] (an :class:`OfLoop` factory)."""
    return lambda omega: loop.open_loop_response(omega)[0]
