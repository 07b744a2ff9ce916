"""Sato's decrease in radius of a linearly interpolated circle (eq 7)."""

from feedtune.loops.protocols import Loop
from feedtune.objectives.base import Magnitude, Metric
from feedtune.objectives.contour.average_radius import polygon_average_radius
from feedtune.objectives.contour.circle import CircleOptions, radius_gain_excess


class RadiusDecrease(Metric):
    """|Δr| [m], Δr = r − r̄·|G(jω)| (Sato eq 7), ω = feed/radius.

    The polygon's average radius r̄ (eq 3) times the loop's gain at the circle's frequency
    (Sato eq 6 for the Padé model; the sampled loop's own |G(e^{jωΔt_p})| for the exact
    one). Written as (r − r̄) − r̄·(|G| − 1) so that slow circles do not cancel to rounding.
    Sato's sign: Δr > 0 when the circle shrinks; the metric is its magnitude. As T → 0 it
    becomes the radial error r·| |G| − 1 | of the loop
    (:class:`~feedtune.objectives.contour.radial_error.RadialError`).
    """

    name = "radius_decrease"
    unit = "m"
    description = "Decrease in radius of the interpolated circle, |r − r̄·|G(jω)|| (Sato eq 7)"
    reference = "Sato et al. eqs 3, 6, 7"
    Options = CircleOptions
    lifted_options = ("radius", "feed")  # ω = feed/radius: arithmetic only

    def supports(self, loop: Loop, options=None):
        return loop.interpolator is not None

    def evaluate(self, loop: Loop, options):
        omega = options.feed / options.radius
        average = polygon_average_radius(options.radius, omega,
                                         loop.interpolator.reference_interval)
        return Magnitude(options.radius - average - average * radius_gain_excess(loop, omega))
