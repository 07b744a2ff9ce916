"""Options shared by the circular-motion metrics: the circle and the feed along it."""

from pydantic import Field, PositiveFloat

from feedtune.model import SpecModel


class CircleOptions(SpecModel):
    """A circle of ``radius`` traversed at path velocity ``feed`` by two identical axes."""

    radius: PositiveFloat = Field(description="Circle radius r [m]")
    feed: PositiveFloat = Field(description="Path velocity V along the circle [m/s]; ω = V/r")
