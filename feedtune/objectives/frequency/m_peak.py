"""Resonance peak M_peak of the closed loop (Bhatia 1971, Ch. IV A a)."""

from feedtune.expr import Supremum
from feedtune.lazy import ca
from feedtune.loops.frequency import log_grid, peak
from feedtune.loops.protocols import Loop
from feedtune.objectives.base import Metric
from feedtune.objectives.frequency.frequency_domain import (has_frequency_band,
                                                            normalised_gain_squared)


class MPeak(Metric):
    """M_peak = max_ω |T(jω)|/|T(0)| [1], located on a grid and refined by Newton's method.

    On a sampled loop T(e^{jωT})/T(1) of the discrete loop, over 0 ≤ ω ≤ π/T (the band may
    reach beyond π/T for a tunable T: the response repeats its values there).
    """

    name = "m_peak"
    unit = "1"
    description = "Peak of the closed-loop gain |position/reference|, normalised to unit DC gain"
    reference = "Bhatia 1971 Ch. IV A (a); M_peak ≤ 1.3"
    reformulated_as = Supremum

    def supports(self, loop: Loop, options=None):
        return has_frequency_band(loop)

    def evaluate(self, loop: Loop, options):
        gain = normalised_gain_squared(loop)
        def locate():  # refined when read (the tuner scans numerically instead)
            value, omega_peak = peak(gain, loop.frequency_band, "m_peak")
            return ca.sqrt(value), omega_peak

        return Supremum(lambda omega: ca.sqrt(gain(omega)), log_grid(loop.frequency_band),
                        locate=locate)
