"""Expression wrappers shared by metrics and the tuner, and the one test of "symbols or numbers".

A metric returns a plain CasADi expression, or one of these when its value is not smooth
in the tunables; the tuner then reformulates it so that the NLP stays smooth
(docs/design.md: non-smooth metrics are reformulated by the tuner, not by each metric).

A Loop holds expressions of the tunables: symbols inside the NLP, numbers on a tuned
design. :func:`is_symbolic` tells them apart and :func:`to_array` / :func:`to_float` give
the numbers of a loop of numbers; every module asks these, none writes its own.
"""

from typing import Callable, NamedTuple

from feedtune.lazy import ca, np


def is_symbolic(*values) -> bool:
    """Whether any of ``values`` depends on a CasADi symbol (an NLP variable or parameter).

    False for numbers (float, int, numpy, ``ca.DM``) and for expressions of numbers only
    (the MX or SX of a loop built from numbers).
    """
    return any(isinstance(v, (ca.SX, ca.MX)) and bool(ca.symvar(v)) for v in values)


def to_array(value) -> "np.ndarray":
    """The numbers of an expression of numbers (or of a number, a DM), as a float array
    of its shape; evaluated by ``casadi.evalf`` (check :func:`is_symbolic` first)."""
    if isinstance(value, (ca.SX, ca.MX)):
        return np.array(ca.evalf(value), dtype=float)
    # a DM, or numbers a DM holds: what evalf would return, without building a Function
    return np.array(value if isinstance(value, ca.DM) else ca.DM(value), dtype=float)


def to_float(value) -> float:
    """The number of a scalar expression of numbers (or of a number), as :func:`to_array`.

    A float (numpy's too) and a 1 × 1 DM are read directly, the same number without the
    DM and array :func:`to_array` makes: 40-50 → 0.1-10 µs a call, the robust search's
    and the tuner's exact evaluations call it for every condition and value (h-tref3)."""
    if isinstance(value, float):
        return float(value)
    if isinstance(value, ca.DM) and value.is_scalar():
        return float(value)
    return float(to_array(value).reshape(-1)[0])


class Magnitude(NamedTuple):
    """|expr|, kept symbolic so that the tuner can use an epigraph instead of fabs."""

    expr: object


class Unbounded(NamedTuple):
    """A value that is +∞ where ``exists`` is 0: the quantity it measures does not exist
    there (a gain margin without a phase crossover: python-control's ``gm = inf``).

    ``finite`` is the value where ``exists`` is 1, and a finite stand-in elsewhere (e.g.
    the margin read at the band's edge), so that the NLP's rows stay finite; ``exact`` is
    the value itself, +∞ where the quantity does not exist. A bound from below holds
    there (∞ ≥ b: the constraint is vacuously satisfied), one from above does not.
    """

    finite: object
    exists: object

    @property
    def exact(self):
        """``finite`` where the quantity exists, else +∞ (an expression)."""
        return ca.if_else(self.exists > 0, self.finite, ca.inf)

    def __float__(self) -> float:
        """The value of a loop of numbers: ``exact``'s number (+∞ where the quantity does
        not exist)."""
        return to_float(self.exact)


class Supremum:
    """max over ω of ``fn(ω) ≥ 0``: a grid of points plus the maximum refined between them.

    ``exact`` is the refined maximum and ``argmax`` the ω [rad/s] where it is taken (0 for
    ω → 0); both are expressions, continuous but not smooth where the maximising peak
    changes. The NLP bounds ``fn`` on the grid (smooth point by point); the tuner then
    checks the refined peak numerically and adds its ω to the points while the bound is
    exceeded (the exchange method for semi-infinite constraints).

    ``exact`` and ``argmax`` are given, or ``locate`` gives them (a callable returning
    (exact, argmax)), called the first time either is read: on a loop of symbols the
    refinement is a large graph (≈ 0.1 s each on issue 16's drive) that the tuner never
    reads, since it starts its variables from a numeric scan.
    """

    __slots__ = ("fn", "grid", "_located", "_locate")

    def __init__(self, fn: Callable, grid, exact=None, argmax=None, *,
                 locate: Callable | None = None):
        self.fn, self.grid = fn, grid  # grid: numpy array of ω [rad/s]
        self._located = None if locate is not None else (exact, argmax)
        self._locate = locate

    def _pair(self):
        if self._located is None:
            self._located = tuple(self._locate())
        return self._located

    @property
    def exact(self):
        """The refined maximum of ``fn`` (an expression)."""
        return self._pair()[0]

    @property
    def argmax(self):
        """The ω [rad/s] of the refined maximum (0 for ω → 0; an expression)."""
        return self._pair()[1]


class Crossing:
    """The lowest ω where ``condition(ω)`` falls to 0 (it is positive below).

    ``exact`` locates it directly (an expression that jumps where a dip touches 0), given
    or computed by ``locate()`` when first read (as :class:`Supremum`). The
    tuner instead makes ω an auxiliary variable b with condition(b·x) ≥ m·(1 − x) on a
    relative grid x ∈ (0, 1) (a small margin m keeps dips off the level), and
    condition(b) = 0 where b must be the crossing itself (≥ 0 when b is maximised or
    bounded from below): a closed, smooth feasible set. ``lowest_minimum(b, m)`` gives
    (min over ω ≤ b of condition(ω) − m·(1 − ω/b), where it is taken [rad/s]), refined
    between grid points; the tuner adds that ω to the points while the minimum is negative. ``condition`` should be bounded (e.g. (g − c)/(g + c) for a gain g ≥ 0),
    so that it stays finite and smooth across a loop's stability boundary.
    """

    __slots__ = ("condition", "relative_grid", "lowest_minimum", "band", "_exact", "_locate")

    def __init__(self, condition: Callable, relative_grid, lowest_minimum: Callable | None,
                 band: tuple, exact=None, *, locate: Callable | None = None):
        self.condition, self.relative_grid = condition, relative_grid  # x in (0, 1)
        # (b, m) ↦ (min over ω ≤ b of condition − m(1 − ω/b), its ω)
        self.lowest_minimum, self.band = lowest_minimum, band
        self._exact, self._locate = exact, locate

    @property
    def exact(self):
        """The crossing [rad/s] (an expression), located when first read."""
        if self._exact is None and self._locate is not None:
            self._exact = self._locate()
        return self._exact


class PoleRegion(NamedTuple):
    """min over the closed-loop poles of a per-pole measure m(p): a decay rate −Re p
    [1/s] or a damping ratio −Re p/|p| [1] (MATLAB's ``TuningGoal.Poles``).

    The minimum over poles is not smooth, so the NLP never sees it: ``conditions(level)``
    gives expressions that are all positive exactly when every pole has m(p) > ``level``
    (an expression), a polynomial test such as the Hurwitz conditions of p(s − σ). The
    tuner bounds the metric from below with those rows, and maximises it with an epigraph
    variable t held by ``conditions(t)``; it can neither bound it from above nor minimise
    it (an upper bound would say "some pole is slow", a union of regions). ``conditions``
    is None where no polynomial test exists (the value is then reported only).

    ``inputs`` is a column expression whose numbers fix the value (the closed-loop state
    matrix and the sampling period) and ``measure`` the numpy function of those numbers
    (the value from the numeric poles); ``exact`` that value on a loop of numbers, NaN on
    a loop of symbols (the tuner evaluates ``measure`` instead). ``lower`` and ``upper``
    bound the measure over stable loops (the epigraph variable's box). ``factors``, where
    given, is the same test on auxiliary variables (:class:`Factors`), which the tuner
    uses instead of ``conditions``.
    """

    conditions: Callable | None
    inputs: object
    measure: Callable
    exact: object
    lower: float
    upper: float
    factors: "Factors | None" = None


class Factors(NamedTuple):
    """A pole region's test written on auxiliary NLP variables x: the real factors of the
    characteristic polynomial, p(s) = ∏(s² + a_i s + b_i)·(s + c), tied to the loop by
    coefficient matching (Vieta), so that "every pole in the region" is a few smooth rows
    per factor (see feedtune.objectives.poles.pole_region).

    ``size`` is len(x); ``start(numbers)`` gives (x, magnitudes of x) [numpy arrays] from
    the numbers of the region's ``inputs`` (the factors of the numeric poles);
    ``matching(x)`` the pairs (residual, magnitude): expressions whose residuals are all 0
    exactly when x factors the loop's polynomial, each magnitude the row's natural size
    (read at a start, it scales the row); ``conditions(level, x)`` expressions all
    positive exactly when every root of every factor has its measure above ``level``.
    """

    size: int
    start: Callable
    matching: Callable
    conditions: Callable
