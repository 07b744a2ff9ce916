"""What every plant declares: its tunable parameters, with units and default bounds, and
the numbers the tuner may lift into NLP parameters.

A plant's ``loop(values, box, horizon_scale=...)`` takes, by name, a value (a number or an
expression) for each tunable and, optionally, for each of its :meth:`Plant.numbers`: a
number given there replaces the spec's own in the loop's arithmetic. The tuner hands the
plant's numbers over as NLP parameters exactly as it hands over fixed tunables, so one
built solver serves every spec that differs only in them (batch tuning).

Everything that shapes the loop's graph (a horizon's sample count, a frequency band, a
choice) keeps reading the spec's own numbers, so a loop built with the numbers in
``values`` equals the one built without them; :meth:`Plant.structure` names those
numbers, so that a spec's structure is known before any graph is built.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Mapping

#: sampled step responses are summed sample by sample over this many times (2τ + dead time),
#: the dead time (computation_delay + 1)·T at the smallest T of the box (the sampled
#: plants: software_servo, linear)
SETTLING_TIME_CONSTANTS = 20.0
#: the sampled loop's frequency band ends this factor above π/T_min: the Nyquist frequency
#: of the fastest sampling is then strictly inside it, in a grid interval of its own
NYQUIST_MARGIN = 1.01


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


class Plant:
    """What the tuner asks of every plant besides its ``tunables()`` and ``loop``.

    The defaults lift nothing: every number of the plant is a constant of its loop's graph,
    and the whole box may shape it.
    """

    params: object

    def numbers(self) -> dict[str, float]:
        """The parameters that enter the loop only through arithmetic, by name, as the spec
        gives them [their units]: ``loop`` also takes them in ``values``. None here."""
        return {}

    def not_uncertain(self) -> dict[str, str]:
        """Parameters (or dotted paths into them) a spec might expect to give as a set or
        a range that this plant cannot take so, each with why (the spec error names it).
        None here: the generic reason is given."""
        return {}

    def uncertainty_problem(self, name: str, low: float, high: float) -> str | None:
        """Why :meth:`numbers`' ``name`` cannot take every value in [low, high] [its unit]
        in one loop of the same structure (a value there would change the model's order or
        type), or None. None here."""
        return None

    def checked_loop(self, values: Mapping[str, float], box: Mapping[str, tuple[float, float]]):
        """The loop at ``values`` (numbers per tunable name) that a spec's checks ask which
        metrics it supports (:func:`feedtune.schema.spec.parse_spec`, ``feedtune
        validate``): ``loop(values, box)`` here. A plant whose loop imports CasADi to be
        built returns a :class:`feedtune.lazy.Deferred` that answers those questions from
        its configuration and builds ``loop(values, box)`` when asked anything else (issue
        15's start-up); the tuner and the evaluations always get ``loop`` itself."""
        return self.loop(values, box)

    def not_tunable(self) -> dict[str, str]:
        """Tunables of the plant type that this configuration fixes, each with the reason a
        spec may not free it. None here."""
        return {}

    def structure(self, box: Mapping[str, tuple[float, float]],
                  horizon_scale: float = 1.0) -> str:
        """What the loop's graph embeds as constants besides the plant's choices, from the
        spec's numbers and the tunables' ``box`` (name → (min, max) [its unit]) at this
        ``horizon_scale``: two specs of equal structure, choices and metrics build equal
        graphs. Here every parameter and the whole box, which is always safe."""
        return json.dumps([self.params.model_dump(mode="json"),
                           {name: list(bounds) for name, bounds in box.items()},
                           horizon_scale], sort_keys=True)

    def embedded_numbers(self, box: Mapping[str, tuple[float, float]],
                         horizon_scale: float = 1.0) -> dict[str, object]:
        """Numbers the loop may embed in its graph, kept out of :meth:`structure`, by the
        name of the loop attribute that holds each (e.g. ``horizon`` [s]): a loop records
        which of them its graph read (``embedded_reads``), and only those separate
        structures (feedtune.tuner.cache.StructureKey). None here: :meth:`structure` holds
        everything."""
        return {}
