"""Expression wrappers shared by metrics and the tuner."""

from typing import NamedTuple


class Magnitude(NamedTuple):
    """|expr|, kept symbolic so that the tuner can use an epigraph instead of fabs."""

    expr: object
