"""Sato's surface roughness of a linearly interpolated circle (eq 10, Table 1)."""

from feedtune.lazy import ca
from feedtune.loops.protocols import Loop
from feedtune.objectives.base import Metric
from feedtune.objectives.contour.circle import CircleOptions

#: Sato Table 1: q = T/Δt_p of each row, and the amplitudes l_{q,k} of the k-th harmonic
#: (k = 1..5) of the chord's radial ripple, normalised to the sagitta r(1 − cos(θ/2)) = 1
TABLE_1_Q = (2, 3, 4, 5, 10, 20, 50)
TABLE_1 = (
    (1.270, 0.0, 0.419, 0.0, 0.247),
    (1.01, 0.454, 0.0, 0.271, 0.0),
    (0.943, 0.313, 0.250, 0.0, 0.0),
    (0.898, 0.209, 0.169, 0.177, 0.0),
    (0.860, 0.223, 0.0, 0.0, 0.0),
    (0.850, 0.213, 0.0, 0.0, 0.0),
    (0.846, 0.209, 0.0, 0.0, 0.0),
)


def _piecewise_linear(x, xs, ys):
    """``ys`` interpolated linearly at ``x`` between ascending ``xs``; constant beyond them."""
    value = ys[0]
    for x0, x1, y0, y1 in zip(xs, xs[1:], ys, ys[1:]):
        value = value + (y1 - y0) / (x1 - x0) * (ca.fmin(ca.fmax(x, x0), x1) - x0)
    return value


def table_1_coefficients(q) -> list:
    """l_{q,k} for k = 1..5 [1] at q = T/Δt_p (Sato Table 1).

    At a tabulated q the row itself. Between rows, linear in 1/q (the rows approach their
    q → ∞ limit about as 1/q: 0.860, 0.850, 0.846 at q = 10, 20, 50), so the coefficients are
    continuous in T and Δt_p. The q = 50 row serves every q ≥ 50 (the paper's own
    conditions, q = 65 and 130, are evaluated with it), the q = 2 row every q ≤ 2.
    """
    inverse = [1 / row_q for row_q in reversed(TABLE_1_Q)]  # ascending 1/q
    rows = list(reversed(TABLE_1))
    return [_piecewise_linear(1 / q, inverse, [row[k] for row in rows]) for k in range(5)]


class SurfaceRoughness(Metric):
    """Δm [m] = r(1 − cos(ωT/2)) Σ_{k=1..5} l_{q,k} |G(jkNω)| (Sato eq 10).

    The chord's radial ripple has the sagitta r(1 − cos(ωT/2)) and the fundamental
    frequency Nω = 2π/T (N = 2π/(ωT) sides, eq 1); its harmonics k = 1..5 with Table 1's
    amplitudes l_{q,k} (q = T/Δt_p; between and beyond the rows see
    :func:`table_1_coefficients`) pass through the loop's gain |G| (eq 9) and are summed
    without phase, an upper bound on the ripple (§3.2.2). For the exact sampled loop |G|
    is |G(e^{jωΔt_p})|: a harmonic above the Nyquist frequency π/Δt_p (only for q < 10) is
    read at its alias, as the samples see it.
    """

    name = "surface_roughness"
    unit = "m"
    description = "Surface roughness of the interpolated circle, ripple gain sum (Sato eq 10)"
    reference = "Sato et al. eqs 1, 9, 10, Table 1"
    Options = CircleOptions
    lifted_options = ("radius", "feed")  # ω = feed/radius: arithmetic only

    def supports(self, loop: Loop, options=None):
        return loop.interpolator is not None

    def evaluate(self, loop: Loop, options):
        interval = loop.interpolator.reference_interval
        omega = options.feed / options.radius
        sagitta = options.radius * 2 * ca.sin(omega * interval / 4) ** 2  # r(1 − cos(ωT/2))
        total = 0
        for k, coefficient in enumerate(
                table_1_coefficients(loop.interpolator.steps_per_interval), start=1):
            re, im = loop.frequency_response(2 * ca.pi * k / interval)  # k·Nω
            total = total + coefficient * ca.sqrt(re**2 + im**2)
        return sagitta * total
