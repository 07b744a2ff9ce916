"""The metric interface: a metric reads a Loop and returns an expression.

A metric never sees a plant. It may decline a Loop (``supports``), for instance a
damping ratio on a loop that is not second order. A metric that is a magnitude |x|
returns :class:`Magnitude`; the tuner reformulates it smoothly (epigraph), so metrics
never smooth anything themselves.
"""

from __future__ import annotations

from typing import ClassVar

from feedtune.expr import Crossing, Magnitude, Supremum  # noqa: F401  (Magnitude re-exported)
from feedtune.loops.protocols import Loop
from feedtune.schema.model import SpecModel


class NoOptions(SpecModel):
    """A metric without options."""


class Metric:
    """Base of every metric module.

    Class attributes: ``name`` (registry key), ``unit`` (SI), ``description``,
    ``reference`` (paper and equation), ``Options`` (pydantic model of its spec options).
    """

    name: ClassVar[str]
    unit: ClassVar[str]
    description: ClassVar[str]
    reference: ClassVar[str] = ""
    Options: ClassVar[type[SpecModel]] = NoOptions
    #: options that enter :meth:`evaluate` only through arithmetic (never a grid size, a
    #: band or a branch), so the tuner may hold them as NLP parameters and reuse one solver
    #: for specs that differ in them (feedtune.problem.LiftedOptions)
    lifted_options: ClassVar[tuple[str, ...]] = ()
    #: "min": the tuner can hold the metric only from below (constraints with ``min``,
    #: objective terms with ``goal: maximize``), e.g. the pole region of a decay rate;
    #: None: both ways
    direction: ClassVar[str | None] = None
    #: where the value is +∞ because the quantity it measures does not exist, in words (a
    #: gain margin without a phase crossover; the value is a :class:`feedtune.expr.Unbounded`);
    #: None: never. A spec may not optimise it where it is +∞ at the box's corners and
    #: centre (feedtune.schema.spec)
    infinite_when: ClassVar[str | None] = None
    #: the kind of value :meth:`evaluate` returns where the tuner reformulates it over ω:
    #: :class:`feedtune.expr.Supremum` (a peak, held on a grid by the exchange method) or
    #: :class:`feedtune.expr.Crossing` (the lowest ω of a condition's zero); None for any
    #: other value (an expression, a Magnitude, an Unbounded or a PoleRegion). Declared, so
    #: that the kind is known without evaluating the metric (the metric contract's cases are
    #: chosen by it at collection; its finite test checks it against every value returned)
    reformulated_as: ClassVar[type[Supremum] | type[Crossing] | None] = None

    def unit_of(self, options, position_unit: str = "m") -> str:
        """SI unit of the value for these options on an axis whose position is in
        ``position_unit`` (m, or rad for a rotary axis); most metrics: ``unit``."""
        return self.unit

    def supports(self, loop: Loop, options=None) -> bool:
        """Whether this metric is defined on ``loop``; by default on every linear loop, never
        on an exact-only loop (a pulse simulation, :class:`feedtune.loops.pulse_train.PulseLoop`),
        whose metrics say so themselves."""
        return not loop.exact_only

    def optimisable(self, loop: Loop, options=None) -> bool:
        """Whether the metric can be an objective term or a constraint on this loop.

        False: reported only, evaluated on the tuned design (e.g. a time response computed
        numerically, which the NLP cannot take).
        """
        return True

    def evaluate(self, loop: Loop, options):
        """The metric's value on ``loop``: an expression, or a :class:`Magnitude`."""
        raise NotImplementedError
