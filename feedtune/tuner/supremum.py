"""Peaks and crossings over frequency as semi-infinite constraints, by the exchange method.

A :class:`~feedtune.expr.Supremum` bound fn(ω) ≤ c is held on a fixed grid, each point
written in a bounded form ((f − c)/(f + c) ≤ 0), so no row blows up where a closed-loop
pole crosses the jω axis. A :class:`~feedtune.expr.Crossing` becomes an auxiliary variable
b with condition(b·x) ≥ DIP_MARGIN·(1 − x) on a relative grid x ∈ (0, 1). After each
solve the refined peak (or dip) is evaluated; while it violates its bound, its frequency
is switched on as one more constraint row (a parameter ``slot`` of the built NLP whose row
bounds are opened until then) and IPOPT runs again from the last solution. Putting the
refined peak itself in the NLP was tried and stalled IPOPT: its value switches between
peaks, so its derivatives jump.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from feedtune.tuner.builder import NlpBuilder

#: frequencies the exchange method may add to one peak or crossing, per start
EXCHANGE_POINTS = 8
#: a refined peak above its bound (relative), or a dip below a crossing condition's zero
#: (the condition is bounded, so absolute), by more than this adds its frequency
EXCHANGE_TOL = 1e-7
#: a crossing's condition must exceed DIP_MARGIN·(1 − x) at ω = b·x below b: without it the
#: optimiser parks a dip exactly on the level (a tangency) and claims the crossing beyond
#: it, where any rounding puts the first crossing at the dip (measured on Bhatia's showcase:
#: 690 rad/s claimed, 471 rad/s by python-control)
DIP_MARGIN = 1e-3


@dataclass
class ExchangeGroup:
    """The exchange rows of one peak or crossing.

    ``bounds`` are the rows' bounds once switched on; ``slots`` and ``rows`` the indices of
    each point's parameter and constraint row; ``violation`` and ``where`` the expressions
    of the refined check (how far the bound is exceeded [1], and at which slot value).
    """

    bounds: tuple[float, float]
    slots: list[int] = field(default_factory=list)
    rows: list[int] = field(default_factory=list)
    violation: object = None
    where: object = None


def exchange_group(builder: NlpBuilder, bounds, default: float, constraint_at,
                   violation, where) -> ExchangeGroup:
    """EXCHANGE_POINTS rows ``constraint_at(slot)``, off until the check switches them on."""
    group = ExchangeGroup(bounds, violation=violation, where=where)
    for _ in range(EXCHANGE_POINTS):
        index, symbol = builder.slot(f"exchange{len(builder.slots)}", default)
        group.slots.append(index)
        group.rows.append(builder.constrain(constraint_at(symbol), -ca.inf, ca.inf))
    return group


def crossing_variable(builder: NlpBuilder, value, index, equality: bool,
                      groups: list[ExchangeGroup]):
    """b = exp(u) [rad/s], the crossing of ``value`` (a Crossing) as an NLP variable.

    condition(b·x) ≥ DIP_MARGIN·(1 − x) on the relative grid and at exchange points;
    condition(b) = 0 when b must be the crossing itself (``equality``), ≥ 0 when it is
    maximised or bounded below. Appends its exchange group to ``groups``.
    """
    lo, hi = value.band
    u = builder.variable(f"log_crossing{index}", math.log(lo), math.log(hi), ca.log(value.exact))
    b = ca.exp(u)
    builder.constrain(value.condition(b), 0, 0 if equality else ca.inf)

    def row(x):
        return value.condition(b * x) - DIP_MARGIN * (1 - x)

    for x in value.relative_grid:
        builder.constrain(row(x), 0, ca.inf)
    dip, where = value.lowest_minimum(b, DIP_MARGIN)
    groups.append(exchange_group(builder, (0, ca.inf), float(value.relative_grid[0]), row,
                                 -dip, where / b))
    return b


def supremum_below(builder: NlpBuilder, value, bound, s, positive: bool,
                   groups: list[ExchangeGroup]) -> None:
    """value.fn(ω) ≤ ``bound`` on the grid and at exchange points (``value`` a Supremum),
    written (fn − bound)/(fn + bound) ≤ 0 when the bound is positive (bounded in [−1, 1]),
    else (fn − bound)/s. Appends its exchange group to ``groups``."""
    def row(omega):
        v = value.fn(omega)
        return (v - bound) / (v + bound) if positive else (v - bound) / s

    for omega in value.grid:
        builder.constrain(row(omega), -ca.inf, 0)
    groups.append(exchange_group(builder, (-ca.inf, 0), float(value.grid[0]), row,
                                 (value.exact - bound) / (ca.fabs(bound) + 1e-300),
                                 value.argmax))


def add_exchange_points(groups: list[ExchangeGroup], violation: np.ndarray, where: np.ndarray,
                        slots: np.ndarray, lbg: np.ndarray, ubg: np.ndarray,
                        used: list[int]) -> bool | None:
    """Switch on a row at every group's violated refined peak/dip (in place).

    ``violation`` and ``where`` hold each group's check at the last solution; ``used``
    counts each group's rows already on. True when points were added, False when nothing
    is violated, None when a group that needs a point has none left.
    """
    added = False
    for number, (group, amount, at) in enumerate(zip(groups, violation, where)):
        if not (amount > EXCHANGE_TOL and math.isfinite(at) and at > 0):
            continue
        if used[number] == len(group.slots):
            return None
        slots[group.slots[used[number]]] = at
        row = group.rows[used[number]]
        lbg[row], ubg[row] = group.bounds
        used[number] += 1
        added = True
    return added
