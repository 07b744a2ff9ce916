"""Steady-state radial error of a circle tracked by two identical axes, exact for the loop."""

from feedtune.loops.protocols import Loop
from feedtune.objectives.base import Magnitude, Metric
from feedtune.objectives.contour.circle import CircleOptions, radius_gain_excess_value


class RadialError(Metric):
    """|e_r| = r·| |H(jω)| − 1 | [m], ω = feed/radius.

    Axis x follows r cos ωt, axis y r sin ωt; both respond with the same complex gain H,
    so the path is a circle of radius r|H|. For a sampled loop H = H(e^{jωT}), the radius
    seen at the sampling instants. Koren's sign convention (eq 28): e_r > 0 when the
    radius grows; the metric is its magnitude.
    """

    name = "radial_error"
    unit = "m"
    description = "Steady-state radial error magnitude on a circle (exact, not only eq 28)"
    reference = "Koren 1979 eqs 28, 37 (exact form)"
    Options = CircleOptions
    lifted_options = ("radius", "feed")  # ω = feed/radius: arithmetic only

    def evaluate(self, loop: Loop, options):
        omega = options.feed / options.radius
        return Magnitude(options.radius * radius_gain_excess_value(loop, omega))
