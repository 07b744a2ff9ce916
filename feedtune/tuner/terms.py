"""Objective terms and constraints as smooth NLP pieces.

A metric's value is a plain expression, a :class:`~feedtune.expr.Magnitude` (|e|), a
:class:`~feedtune.expr.Supremum` (a peak over ω) or a :class:`~feedtune.expr.Crossing`
(the first ω where a condition falls to 0) or a :class:`~feedtune.expr.PoleRegion` (the
least decay rate or damping of the poles) or an :class:`~feedtune.expr.Unbounded` (+∞ where
its quantity does not exist). Magnitudes become epigraphs (a slack t with
−t ≤ e ≤ t), peaks epigraphs over the frequency grid, crossings an auxiliary variable
(feedtune.tuner.supremum), pole regions the Hurwitz rows of their polynomial test
(feedtune.tuner.poles), unbounded values their finite stand-in, so the NLP stays smooth
and finite. Every row is divided by a scale, an
NLP parameter, so one built solver serves specs of other magnitudes.
"""

from __future__ import annotations

import casadi as ca

from feedtune.expr import Crossing, Magnitude, PoleRegion, Supremum, Unbounded
from feedtune.tuner.builder import Lazy, NlpBuilder, scale
from feedtune.tuner.poles import region_bound, region_term
from feedtune.tuner.supremum import ExchangeGroup, crossing_variable, supremum_below
from feedtune.tuner.types import Bound


def exact_value(value) -> tuple[object, bool]:
    """(expression, is |·|): the exact value the result reports, for any metric value."""
    if isinstance(value, Magnitude):
        return value.expr, True
    if isinstance(value, (Supremum, Crossing, PoleRegion, Unbounded)):
        return value.exact, False
    return value, False


def unbounded_row(value: Unbounded, s, lower: float, upper: float):
    """The row of an :class:`~feedtune.expr.Unbounded` value for ``lower ≤ value/s ≤
    upper`` (``s`` the bound's scale; ``lower``, ``upper`` divided by it, ±inf where a side
    is open): value/s where its quantity exists; where it does not (the value is +∞), a
    number the row's bounds accept when only ``lower`` binds (∞ ≥ lower: vacuously
    satisfied) and refuse, by one scale, when ``upper`` does (∞ > upper)."""
    row = value.finite / s
    stand = upper + 1 if upper < ca.inf else lower
    return ca.if_else(value.exists > 0, row, ca.fmax(row, stand))


def add_term(builder: NlpBuilder, index: int, value, scan, weight, sign: float,
             reference: float | None, groups: list[ExchangeGroup]):
    """The NLP's share of objective term ``index``: ``weight`` (a parameter) times its value.

    ``sign`` is the term's signed weight: its sign shapes the NLP (an epigraph only bounds
    what is minimised), its size is the parameter. ``reference`` is the term's magnitude
    at the starts (see feedtune.tuner.builder.Scales); ``scan`` the numeric scan of a
    Supremum or Crossing value (feedtune.tuner.supremum.make_scan). The share is None
    from a builder that is not symbolic (a magnitude's or a plain value's rows and share
    are :class:`~feedtune.tuner.builder.Lazy`).
    """
    magnitude = isinstance(value, Magnitude)  # exact_value only where read: on a loop of
    # symbols a Supremum's or Crossing's exact value is a large graph the NLP does not use
    if isinstance(value, Crossing):
        return weight * crossing_variable(builder, value, scan, index, sign > 0, groups)
    if isinstance(value, Unbounded):  # maximised (or minimised) where it is finite; a tuned
        # point where it is +∞ has no finite objective
        return builder.expression(Lazy(lambda: weight * value.finite))
    if isinstance(value, PoleRegion):
        if sign > 0:  # "some pole is slow" is a union of regions: no smooth rows
            raise ValueError("a pole region (decay rate, damping) can only be maximised")
        return weight * region_term(builder, value, index, reference)
    if isinstance(value, Supremum) and sign > 0:  # epigraph: fn(ω) ≤ s·t, minimise
        s = builder.parameter(f"term_scale{index}", scale(reference))
        t = builder.variable(f"peak{index}", 0, ca.inf, lambda peak: peak / s * 1.01, scan)
        supremum_below(builder, value, scan, s * t, s, True, groups)
        return weight * s * t
    expr = exact_value(value)[0]
    if magnitude and sign < 0:  # maximising |e|: no epigraph bounds it from above
        return builder.expression(Lazy(lambda: weight * ca.fabs(expr)))
    if magnitude:  # epigraph: −s·t ≤ e ≤ s·t, minimise s·t
        s = builder.parameter(f"term_scale{index}", scale(reference))
        t = builder.variable(f"slack{index}", 0, ca.inf,
                             Lazy(lambda: ca.fabs(expr) / s * 1.01 + 1e-6))
        builder.constrain(Lazy(lambda: (expr - s * t) / s), -ca.inf, 0)
        builder.constrain(Lazy(lambda: (expr + s * t) / s), 0, ca.inf)
        return builder.expression(Lazy(lambda: weight * s * t))
    return builder.expression(Lazy(lambda: weight * expr))


def add_bound(builder: NlpBuilder, index: int, value, scan, bound: Bound,
              reference: float | None, groups: list[ExchangeGroup]) -> None:
    """Rows holding ``bound.lower ≤ value ≤ bound.upper``, divided by the bound's scale
    (``scan`` as for :func:`add_term`)."""
    magnitude = isinstance(value, Magnitude)  # exact_value only where read, as add_term
    s_value = scale(bound.lower, bound.upper) if (bound.lower or bound.upper) else scale(reference)
    s = builder.parameter(f"bound_scale{index}", s_value)
    lower = bound.lower / s_value if bound.lower is not None else -ca.inf
    upper = bound.upper / s_value if bound.upper is not None else ca.inf
    if isinstance(value, PoleRegion):
        if bound.upper is not None:
            raise ValueError("a pole region (decay rate, damping) can only be bounded from below")
        region_bound(builder, value, index, bound.lower)
    elif isinstance(value, Crossing):
        b = crossing_variable(builder, value, scan, f"_bound{index}", bound.upper is not None,
                              groups)
        builder.constrain(b / s, lower, upper)
    elif isinstance(value, Supremum) and bound.upper is not None:
        supremum_below(builder, value, scan, builder.parameter(f"bound_upper{index}", bound.upper),
                       s, bound.upper > 0, groups)
        if bound.lower is not None:
            builder.constrain(value.exact / s, lower, ca.inf)
    elif isinstance(value, Unbounded):
        builder.constrain(Lazy(lambda: unbounded_row(value, s, lower, upper)), lower, upper)
    elif magnitude and bound.lower is not None and bound.lower > 0:
        builder.constrain(Lazy(lambda: value.expr**2 / s**2), lower**2,
                          upper**2 if bound.upper is not None else ca.inf)
    elif magnitude:
        builder.constrain(Lazy(lambda: value.expr / s), -upper, upper)
    else:
        builder.constrain(Lazy(lambda: exact_value(value)[0] / s), lower, upper)
