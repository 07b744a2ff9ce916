"""What every plant declares: its tunable parameters, with units and default bounds.

Optionally, a plant lets the tuner reuse one built solver across specs that differ only in
some of its own numbers (batch tuning). It then offers

* ``numbers() -> dict[str, float]``: the parameters that enter its loop only through
  arithmetic (e.g. a time constant), by name, as the spec gives them; and
* ``loop(values, box, horizon_scale=..., numbers=None)``: ``numbers`` maps some of those
  names to expressions (NLP parameters) that the loop computes with instead.

Everything that shapes the loop's graph (a horizon's sample count, a frequency band, a
choice) keeps reading the spec's own numbers, so the loop built with ``numbers`` equals
the one built without at ``numbers()``. A plant without ``numbers`` has its numbers
embedded as constants: correct, just never shared between specs that differ in them.
"""

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
    required : bool
        The spec must give it (bounds or a value): its default box fits no drive in general.
    """

    unit: str
    description: str
    min: float
    max: float
    required: bool = False
