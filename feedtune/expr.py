"""Expression wrappers shared by metrics and the tuner.

A metric returns a plain CasADi expression, or one of these when its value is not smooth
in the tunables; the tuner then reformulates it so that the NLP stays smooth
(DESIGN.md: non-smooth metrics are reformulated by the tuner, not by each metric).
"""

from typing import Callable, NamedTuple


class Magnitude(NamedTuple):
    """|expr|, kept symbolic so that the tuner can use an epigraph instead of fabs."""

    expr: object


class Supremum(NamedTuple):
    """max over ω of ``fn(ω)``: a grid of points plus the maximum refined between them.

    ``exact`` is the refined maximum (an expression, continuous but not smooth where the
    maximising peak changes). The tuner bounds every grid value and the refined one
    (``fn(ω_k) ≤ t`` for all k), which is smooth point by point.
    """

    fn: Callable
    grid: object  # numpy array of ω [rad/s]
    exact: object


class Crossing(NamedTuple):
    """The lowest ω where ``condition(ω)`` falls to 0 (it is positive below).

    ``exact`` locates it directly (an expression that jumps where a dip touches 0). The
    tuner instead makes ω an auxiliary variable b with condition(b) = 0 and
    condition(b·x) ≥ 0 on a relative grid x ∈ (0, 1) plus the refined minimum there:
    a closed, smooth feasible set on which "maximise b" is well posed.
    """

    condition: Callable
    relative_grid: object  # numpy array of x in (0, 1)
    lowest_minimum: Callable  # b ↦ min over ω ≤ b of condition, refined between grid points
    band: tuple
    exact: object
