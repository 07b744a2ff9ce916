"""Sato's average radius: the circle a linearly interpolated polygon is equivalent to (eq 3)."""

from feedtune.lazy import ca
from feedtune.loops.protocols import Loop
from feedtune.objectives.base import Metric
from feedtune.objectives.contour.circle import CircleOptions


def polygon_average_radius(radius, omega, interval):
    """r̄ = r·√(sin(ωT)/(ωT)) [m], Sato eq 3.

    The radius of the circle whose area equals that of the polygon inscribed in a circle of
    ``radius`` r [m] with a vertex every ``interval`` T [s] at ``omega`` ω [rad/s]: N =
    2π/(ωT) sides (eq 1), each a triangle of area r² cos(θ/2) sin(θ/2) with θ = 2π/N = ωT
    (eq 2). Defined for ωT < π (more than two sides).
    """
    angle = omega * interval  # θ = ωT [rad]
    return radius * ca.sqrt(ca.sin(angle) / angle)


class AverageRadius(Metric):
    """r̄ [m] of the circle drawn as a polygon, a vertex every reference interval T (eq 3).

    Depends on the interpolator only (r, ω = feed/radius, T), not on the servo; what the
    servo makes of the polygon is
    :class:`~feedtune.objectives.contour.radius_decrease.RadiusDecrease`.
    """

    name = "average_radius"
    unit = "m"
    description = "Radius of the circle with the area of the interpolated polygon (Sato eq 3)"
    reference = "Sato et al. eqs 1–3"
    Options = CircleOptions
    lifted_options = ("radius", "feed")  # ω = feed/radius: arithmetic only

    def supports(self, loop: Loop, options=None):
        return loop.interpolator is not None

    def evaluate(self, loop: Loop, options):
        return polygon_average_radius(options.radius, options.feed / options.radius,
                                      loop.interpolator.reference_interval)
