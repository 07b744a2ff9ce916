"""A loop of numbers' parametric twin: the same loop on CasADi symbols, one per structure.

Evaluating a tuned design builds, for each peak, crossing and scan, a CasADi graph on a
loop whose matrices are numbers, differentiates it and expands it (issue 15: ≈ 30 ms a
batch spec of the software servo). Two loops that differ only in their numbers build the
same graph with other constants. So a loop of numbers is described here as a *structure*
(its class, every integer, flag and choice, the sparsity of every matrix, which numbers
are exactly 0 or ±1) and a vector of its other *numbers* (floats, nonzeros of matrices);
the structure's twin is the loop rebuilt with those numbers replaced by the entries of
one MX symbol. Functions built once on the twin (:func:`feedtune.loops.frequency.replayed`)
then serve every loop of that structure, called with its numbers.

The twin's graph performs the operations the loop of numbers' graph performs, on
parameters instead of folded constants. They differ only where CasADi simplifies on
constant values: 0 and ±1 stay constants of the twin, so x·1 and x + 0 fold alike; what
remains is a sum that cancels in floats on the loop of numbers and exactly on the twin
(x + (y − x) → y), as a sampled loop's D(1) = 1 − (1 + x) + x: its M_peak and bandwidth
move by ≤ 1.8e-13 relative, towards the exact value (docs/design.md). A number that
shapes a graph (a count of terms, a Python branch) raises on the symbol, and the caller
then builds on the loop of numbers as before.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Callable

from feedtune.lazy import ca, np
from feedtune.lru import Lru

#: twins kept: one per loop structure, a batch holds a few; structure → (twin loop, numbers
#: symbol, the structure)
_TWIN_CACHE_SIZE = 64
_twins = Lru(_TWIN_CACHE_SIZE)
#: Functions of a structure's twin numbers (:func:`replayed_numbers`): (name, structure) →
#: the Function, or False (not replayable)
_NUMBERS_CACHE_SIZE = 256
_numbers_functions = Lru(_NUMBERS_CACHE_SIZE)
#: keys (a name, the loop's structure, …) of the Functions asked for (:func:`asked_before`),
#: as many as Functions kept
_ASKED_SIZE = 256
_asked = Lru(_ASKED_SIZE)


class NoTwin(Exception):
    """Raised while describing a loop that holds symbols or an unknown kind of value."""


@dataclass(frozen=True, eq=False)
class Twin:
    """A loop of numbers as (structure, its twin, the twin's symbol, this loop's numbers).

    Attributes
    ----------
    structure : tuple
        Hashable: equal for two loops whose twins are the same graph.
    loop
        The loop rebuilt on the entries of ``numbers`` (shared by every loop of the
        structure).
    numbers : casadi.MX
        The twin's symbol, a column of every number of the loop.
    values : numpy.ndarray
        This loop's numbers, in the order of ``numbers``.
    """

    structure: tuple
    loop: object
    numbers: object
    values: np.ndarray


class _Leaves:
    """The numbers met while describing a value, in order: each a float, a DM (its
    sparsity kept), or an MX of numbers evaluated together at the end."""

    def __init__(self):
        self.items: list = []

    def add(self, value) -> tuple:
        self.items.append(value)
        return ("number", _sparsity_key(value))


#: numbers kept as constants of the twin (in its structure): CasADi folds x·0, x·1, x + 0
#: on them, as it does on the loop of numbers' graph (a structural 0 of a matrix, a unit
#: coefficient), so the twin's graph is as short as that one and its values its bits
CONSTANTS = (0.0, 1.0, -1.0)


def _sparsity_key(value) -> tuple:
    if isinstance(value, float):
        return (1, 1, (0, 1), (0,))
    sp = value.sparsity()
    return (sp.size1(), sp.size2(), tuple(sp.colind()), tuple(sp.row()))


def _describe(value, leaves: _Leaves, fields: Callable):
    """The structure of ``value``: numbers become ("number", shape) and go to ``leaves``."""
    if value is None or isinstance(value, (bool, int, str)):
        return value
    if isinstance(value, (float, np.floating)):
        return ("constant", float(value)) if value in CONSTANTS else leaves.add(float(value))
    if isinstance(value, ca.DM):
        return leaves.add(value)
    if isinstance(value, ca.SX):
        if ca.symvar(value):
            raise NoTwin("a symbol")  # a loop inside the NLP
        return leaves.add(ca.evalf(value))
    if isinstance(value, ca.MX):  # a symbol in it: found where the twin's numbers are
        return leaves.add(value)  # evaluated (_twin_of), without a walk of its graph here
    if isinstance(value, (tuple, list)):
        return (type(value).__name__, tuple(_describe(v, leaves, fields) for v in value))
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return (type(value), tuple((name, _describe(v, leaves, fields))
                                   for name, v in fields(value)))
    raise NoTwin(f"a {type(value).__name__}")


def _fields(value) -> list[tuple[str, object]]:
    """A dataclass's init fields and values, read from its ``__dict__`` where they are
    kept (a loop's :class:`~feedtune.loops.loop.EmbeddedNumber` records every read through
    its attribute; the twin is no read of the loop's graph)."""
    return [(f.name, value.__dict__[f.name] if f.name in value.__dict__ else getattr(value, f.name))
            for f in dataclasses.fields(value) if f.init]


def _rebuild(value, take: Callable):
    """``value`` with every number replaced by ``take(number)`` (the twin's entries)."""
    if value is None or isinstance(value, (bool, int, str)):
        return value
    if isinstance(value, (float, np.floating)) and value in CONSTANTS:
        return value
    if isinstance(value, (float, np.floating, ca.DM, ca.MX, ca.SX)):
        return take(value)
    if isinstance(value, (tuple, list)):
        return type(value)(_rebuild(v, take) for v in value)
    return type(value)(**{name: _rebuild(v, take) for name, v in _fields(value)})


def parametric_twin(loop) -> Twin | None:
    """The :class:`Twin` of a loop of numbers, or None for a loop that holds symbols (inside
    the NLP) or a value of a kind not described here. The twin of a structure is built on
    its first loop and kept (an LRU of 64); ``values`` are this loop's numbers.

    Kept on the loop (in its ``__dict__``, as a cached property is), so the reports of one
    tuned design describe it once.
    """
    if "_parametric_twin" in loop.__dict__:
        return loop.__dict__["_parametric_twin"]
    twin = None
    if dataclasses.is_dataclass(loop):
        leaves = _Leaves()
        try:
            structure = _describe(loop, leaves, _fields)
        except NoTwin:
            structure = None
        if structure is not None:
            try:
                twin = _twin_of(loop, structure, leaves.items)
            except NoTwin:
                twin = None
    loop.__dict__["_parametric_twin"] = twin
    return twin


def _twin_of(loop, structure: tuple, items: list) -> Twin:
    symbolic = [i for i, v in enumerate(items) if isinstance(v, ca.MX)]
    evaluated = list(items)
    if symbolic:  # expressions of numbers: evaluated together, once
        try:
            numbers_of = ca.Function("twin_numbers", [], [items[i] for i in symbolic])
        except RuntimeError as exc:  # a loop inside the NLP: CasADi finds its symbols
            if "are free" in str(exc):  # while it builds (≈ 70-130 µs less a tuned design
                raise NoTwin("a symbol") from None  # than ca.symvar on every leaf first)
            raise
        results = numbers_of.call([])
        for i, value in zip(symbolic, results):
            evaluated[i] = value
    entries = [[v] if isinstance(v, float) else list(v.nonzeros()) for v in evaluated]
    # which entries stay constants (CONSTANTS), per leaf: part of the structure
    kept = tuple(tuple(x if x in CONSTANTS else None for x in leaf) for leaf in entries)
    values = np.array([x for leaf in entries for x in leaf if x not in CONSTANTS], float)
    structure = (structure, kept)
    kept_twin = _twins.get(structure)
    if kept_twin is not None:
        # the structure kept with the twin, not this loop's equal copy: the keys of the
        # Functions replayed on it (``frequency.replayed``: ≈ 10 look-ups a tuned design)
        # then compare it by identity instead of element by element
        twin_loop, numbers, structure = kept_twin
    else:
        numbers = ca.MX.sym("numbers", values.size)
        offset, leaf_index = 0, 0

        def take(value):
            nonlocal offset, leaf_index
            parts = []
            for constant in kept[leaf_index]:
                if constant is None:
                    parts.append(numbers[offset])
                    offset += 1
                else:
                    parts.append(ca.MX(constant))
            leaf_index += 1
            if isinstance(value, (float, np.floating)):
                return parts[0]
            return ca.MX(value.sparsity(), ca.vertcat(*parts))

        twin_loop = _rebuild(loop, take)
        _twins.put(structure, (twin_loop, numbers, structure))
    return Twin(structure, twin_loop, numbers, values)


def asked_before(key: tuple) -> bool:
    """Whether a Function of ``key`` (its name, the loop's structure, …) was asked for
    before, recording that it is now. A Function replayed on a structure's twin is built
    from its second request on: building it costs a few graphs, which a single tuning,
    seeing one loop of a structure, would pay for one value (issue 15)."""
    before = _asked.get(key, False)
    _asked.put(key, True)
    return before


def replayed_numbers(loop, name: str, values_of: Callable) -> list | None:
    """``values_of(loop)`` (a list of the loop's expressions: matrices, coefficients) as DM
    numbers, through one Function of the loop structure's twin numbers, called with this
    loop's (issue 15: a loop of numbers otherwise builds the graph of its constants and a
    Function of it for one evaluation, ≈ 0.3-0.5 ms a tuned design). The Function performs
    the operations of that graph on the twin's entries (the module's docstring), so the
    same bits; ``name`` with the structure is its key.

    None where the caller evaluates the graph itself: a loop of symbols or without a
    twin, an expression that is not a Function of the twin's numbers, and the first
    request of a (name, structure) (:func:`asked_before`)."""
    twin = parametric_twin(loop)
    if twin is None:
        return None
    key = (name, twin.structure)
    function = _numbers_functions.get(key)
    if function is None:
        if not asked_before(("numbers", *key)):
            return None
        try:
            function = ca.Function(name, [twin.numbers],
                                   [ca.MX(v) for v in values_of(twin.loop)])
        except RuntimeError as exc:  # a symbol besides the twin's numbers
            if "are free" not in str(exc):
                raise
            function = False
        _numbers_functions.put(key, function)
    if function is False:
        return None
    return function.call([ca.DM(twin.values)])


def replayed_expressions(loop, name: str) -> list | None:
    """The outputs of :func:`replayed_numbers`' Function ``name`` for ``loop``'s structure,
    called in a graph on the loop's numbers, or None while that Function is not built (it
    is not asked for here). A call is a node of the graph, not a constant: what is built
    on its outputs simplifies as on the graph it replaces (√c squared folds to c), and
    evaluated it gives the same bits."""
    twin = parametric_twin(loop)
    if twin is None:
        return None
    function = _numbers_functions.get((name, twin.structure))
    if not isinstance(function, ca.Function):
        return None
    return function.call([ca.MX(ca.DM(twin.values))])


class OfLoop:
    """ω ↦ ``factory(loop, *args)(ω)``: a function of a loop's frequency response that
    names its loop and how it was made, so that a loop of numbers can evaluate it through
    Functions built once on its structure's twin (:func:`feedtune.loops.frequency.replayed`).

    ``factory`` is a module-level function and ``args`` hashable: together they are the
    key of those Functions. Called, it is exactly ``factory(loop, *args)`` (made once).
    """

    __slots__ = ("factory", "loop", "args", "_fn")

    def __init__(self, factory: Callable, loop, *args):
        self.factory, self.loop, self.args = factory, loop, args
        self._fn = None

    @property
    def key(self) -> tuple:
        """(factory, args): the same for the function on every loop."""
        return (self.factory, self.args)

    def on(self, loop) -> Callable:
        """``factory(loop, *args)``: the same function made on another loop (the twin)."""
        return self.factory(loop, *self.args)

    def __call__(self, omega):
        if self._fn is None:
            self._fn = self.factory(self.loop, *self.args)
        return self._fn(omega)
