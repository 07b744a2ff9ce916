"""Options shared by the circular-motion metrics, and the radius gain |H| − 1."""

from pydantic import Field, PositiveFloat

from feedtune.lazy import ca
from feedtune.loops.protocols import Loop
from feedtune.schema.model import SpecModel


class CircleOptions(SpecModel):
    """A circle of ``radius`` traversed at path velocity ``feed`` by two identical axes."""

    radius: PositiveFloat = Field(description="Circle radius r [m]")
    feed: PositiveFloat = Field(description="Path velocity V along the circle [m/s]; ω = V/r")


def radius_gain_excess(loop: Loop, omega):
    """|H(jω)| − 1 [1], the relative radius error of a circle tracked at ω [rad/s].

    From S = 1 − H: |H|² − 1 = |S|² − 2 Re S, divided by |H| + 1; accurate where the
    plain |H| − 1 would cancel to rounding (slow circles, large radii).
    """
    s_re, s_im = loop.error_response(omega)
    gain = ca.sqrt((1 - s_re) ** 2 + s_im**2)
    return (s_re**2 + s_im**2 - 2 * s_re) / (gain + 1)
