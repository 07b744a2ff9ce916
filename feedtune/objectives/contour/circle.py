"""Options shared by the circular-motion metrics, and the radius gain |H| − 1."""

from pydantic import Field, PositiveFloat

from feedtune.lazy import ca
from feedtune.loops.frequency import value_at
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


def _radius_gain_excess_of(loop: Loop):
    """ω ↦ :func:`radius_gain_excess` of ``loop`` at ω (an :class:`OfLoop` factory)."""
    return lambda omega: radius_gain_excess(loop, omega)


def radius_gain_excess_value(loop: Loop, omega):
    """:func:`radius_gain_excess` [1]; for a loop of numbers and a float ω [rad/s] its
    number (a DM), evaluated by the Function replayed on the loop's twin
    (:func:`feedtune.loops.frequency.value_at`: the same operations, no graph built)."""
    return value_at("radius_gain_excess", _radius_gain_excess_of, loop, omega)
