"""Peak of the sensitivity function, M_s = max |1/(1 + L(jω))| (the robustness measure of
Åström and Hägglund; its inverse is the distance from L to −1)."""

from feedtune.expr import Supremum
from feedtune.lazy import ca
from feedtune.loops.frequency import log_grid, peak
from feedtune.loops.protocols import Loop
from feedtune.loops.twin import OfLoop
from feedtune.objectives.base import Metric
from feedtune.objectives.frequency.frequency_domain import has_open_loop


def sensitivity_squared(loop: Loop):
    """ω ↦ |S(jω)|² [1] of the loop's ``sensitivity_response``."""
    def gain(omega):
        re, im = loop.sensitivity_response(omega)
        return re**2 + im**2

    return gain


class SensitivityPeak(Metric):
    """M_s = max_ω |S(jω)| [1], S = 1/(1 + L) = 1 − T the error per reference of a unity
    feedback loop; 1/M_s is the shortest distance from the Nyquist curve of L to −1, so
    M_s ≤ 2 guarantees a gain margin ≥ 2 and a phase margin ≥ 29°.

    Not Bhatia's ``sensitivity`` (the loop-gain product |G K'_v K'_p| that makes the closed
    loop insensitive to the plant at low frequency): a peak over all frequencies, located
    on a grid and refined by golden section and Newton steps, held in the NLP as a
    supremum (the exchange method), as ``m_peak``. S is the loop's ``sensitivity_response``
    (den L/(den L + num L), exact at low ω; the error per reference unless a feed-forward
    makes the reference path differ from the feedback path).
    """

    name = "sensitivity_peak"
    unit = "1"
    description = ("Sensitivity peak M_s = max |1/(1 + L(jw))| over frequency [1]; not "
                   "Bhatia's 'sensitivity' (a loop-gain product)")
    reference = "Åström & Hägglund, Advanced PID Control (2006) §4.2, M_s; 1/M_s = min |1 + L|"
    reformulated_as = Supremum

    def supports(self, loop: Loop, options=None):
        return has_open_loop(loop)

    def evaluate(self, loop: Loop, options):
        gain = OfLoop(sensitivity_squared, loop)

        def locate():  # refined when read (the tuner scans numerically instead)
            value, omega_peak = peak(gain, loop.frequency_band, "sensitivity_peak")
            return ca.sqrt(value), omega_peak

        return Supremum(lambda omega: ca.sqrt(gain(omega)), log_grid(loop.frequency_band),
                        locate=locate)
