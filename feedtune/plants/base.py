"""What every plant declares: its tunable parameters, with units and default bounds."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Tunable:
    """A parameter the tuner may choose.

    Attributes
    ----------
    unit : str
        SI unit, as shown in ``feedtune plants``.
    description : str
    min, max : float
        Default bounds used when the spec does not narrow them (both > 0: the tuner works
        on the logarithm of every tunable).
    """

    unit: str
    description: str
    min: float
    max: float
