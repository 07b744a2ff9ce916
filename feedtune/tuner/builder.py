"""The NLP under construction: its variables, parameters, constraint rows and scales.

The NLP's variables are the logarithms of the free tunables (``z``) followed by auxiliary
variables (epigraph slacks, crossing frequencies). Every number of a problem that shapes
no graph is an NLP parameter (``p``): fixed tunable values, the plant's numbers, objective
weights, bounds inside the graph and every scale found by probing the starts, so that one
built solver serves every spec of the same structure (feedtune.tuner.cache). Exchange
points (frequencies added while solving, feedtune.tuner.supremum) are parameters too,
held apart as ``slots``.

A problem of a structure built before (feedtune.tuner.structure) needs only its own
numbers (parameter values, row and variable bounds, scales): its builder is not
``symbolic``, and the rows, starts and objective the pieces hand it as :class:`Lazy` are
not built (each CasADi operation from Python costs ≈ 50 µs of argument conversion; a batch
spec's objective, bound and stability rows ≈ 1 ms on a structure hit). The numbers are
computed by the same code either way.
"""

from __future__ import annotations

import math
import casadi as ca
import numpy as np

from feedtune.tuner.types import Variable


class Lazy:
    """An NLP expression built only by a ``symbolic`` :class:`NlpBuilder`, from ``make``
    (a function of nothing), once; ``size`` its number of entries (rows, for a
    constraint)."""

    def __init__(self, make, size: int = 1):
        self._make, self.size, self._built = make, size, None

    def build(self):
        """The expression (made on the first call, the same object after)."""
        if self._built is None:
            self._built = self._make()
        return self._built


class NlpBuilder:
    """Collects the NLP piece by piece; each ``add_*`` returns what the caller needs later
    (a symbol, or a row's index).

    ``symbolic`` false: :class:`Lazy` expressions are left unbuilt (:meth:`expression`
    gives None for them), for a problem that reuses a built structure's Functions."""

    def __init__(self, variables: list[Variable], z: ca.MX | None = None,
                 symbolic: bool = True):
        self.variables = variables
        self.symbolic = symbolic
        self.z = ca.MX.sym("log_tunables", len(variables)) if z is None else z
        self._params: list[ca.MX] = []
        self._param_values: list[float] = []
        self._extra: list[ca.MX] = []
        self._extra_lower: list[float] = []
        self._extra_upper: list[float] = []
        self.extra_start: list = []  # start of each auxiliary variable, an expression of z
        self.scanned: list[ca.MX] = []  # symbols of numerically scanned values starts read
        #: auxiliary variables (indices among them) that the tunables define, such as the
        #: factors of a polynomial: a resumed attempt starts them afresh from its z
        self.restarted: list[int] = []
        self.start_scans: list = []  # the scan giving each (its ``exact(z, p)``)
        self._blocks: list = []  # each constrain's expression, or constrain_all's vector
        self._lbg: list[float] = []
        self._ubg: list[float] = []
        self.slots: list[ca.MX] = []
        self._slot_defaults: list[float] = []

    def parameter(self, name: str, value: float, symbol: ca.MX | None = None) -> ca.MX:
        """A new NLP parameter holding ``value`` for this problem; its symbol (``symbol``
        when given: a parameter of a structure built before, see feedtune.tuner.structure)."""
        symbol = ca.MX.sym(name) if symbol is None else symbol
        self._params.append(symbol)
        self._param_values.append(float(value))
        return symbol

    def expression(self, expr):
        """``expr`` itself, or a :class:`Lazy` one built (None when not :attr:`symbolic`)."""
        if isinstance(expr, Lazy):
            return expr.build() if self.symbolic else None
        return expr

    def variable(self, name: str, lower: float, upper: float, start, scan=None) -> ca.MX:
        """A new auxiliary NLP variable in [lower, upper], started at ``start`` (an
        expression of z); its symbol. With a ``scan`` (feedtune.tuner.supremum.make_scan),
        ``start`` maps the scan's value at each start, a symbol filled in numerically
        (:meth:`scanned_values`), to the start: the exact peak or crossing is never built
        as a graph of z."""
        if scan is not None:
            value = ca.MX.sym(f"{name}_scanned")
            self.scanned.append(value)
            self.start_scans.append(scan)
            start = start(value)
        start = self.expression(start)  # built before this variable exists, as when eager
        symbol = ca.MX.sym(name)
        self._extra.append(symbol)
        self._extra_lower.append(lower)
        self._extra_upper.append(upper)
        self.extra_start.append(start)
        return symbol

    def constrain(self, expr, lower: float, upper: float) -> int:
        """Constraint row ``lower ≤ expr ≤ upper``; its index."""
        return self.constrain_all(expr, lower, upper)[0]

    def constrain_all(self, expr, lower: float, upper: float) -> range:
        """One row ``lower ≤ e ≤ upper`` per entry e of the vector ``expr`` (or
        :class:`Lazy`); their indices.

        The vector is kept whole (:attr:`g`): split into one MX node per entry, a grid of
        rows was 560 of the user drive's 1 444 MX nodes and, differentiated in 9
        directions, most of its unexpanded Jacobian."""
        start = len(self._lbg)
        size = expr.size if isinstance(expr, Lazy) else expr.numel()
        self._blocks.append(self.expression(expr))
        self._lbg.extend([lower] * size)
        self._ubg.extend([upper] * size)
        return range(start, len(self._lbg))

    @property
    def g(self) -> ca.MX:
        """Every constraint row, in index order, as one column."""
        return ca.vertcat(ca.MX(0, 1), *[ca.vec(block) for block in self._blocks])

    def scanned_values(self, z, p) -> list[float]:
        """The value of every scan a start reads (:meth:`variable`) at log tunables ``z``,
        parameters ``p``."""
        return [scan.exact(z, p) for scan in self.start_scans]

    def slot(self, name: str, default: float) -> tuple[int, ca.MX]:
        """An exchange point: a parameter set while solving (``default`` until then); its
        index among the slots and its symbol."""
        symbol = ca.MX.sym(name)
        self.slots.append(symbol)
        self._slot_defaults.append(float(default))
        return len(self.slots) - 1, symbol

    @property
    def n_z(self) -> int:
        return len(self.variables)

    @property
    def extra(self) -> list[ca.MX]:
        """The auxiliary variables' symbols."""
        return list(self._extra)

    @property
    def w(self) -> ca.MX:
        """Every NLP variable: z, then the auxiliary ones."""
        return ca.vertcat(self.z, *self._extra)

    @property
    def p(self) -> ca.MX:
        """Every parameter but the slots."""
        return ca.vertcat(ca.MX(0, 1), *self._params)

    @property
    def parameters(self) -> list[ca.MX]:
        """Every parameter's symbol but the slots, in the order made."""
        return list(self._params)

    @property
    def param_values(self) -> np.ndarray:
        return np.array(self._param_values, dtype=float)

    @property
    def slot_defaults(self) -> np.ndarray:
        return np.array(self._slot_defaults, dtype=float)

    @property
    def lbw(self) -> np.ndarray:
        return np.concatenate([np.log([v.lower for v in self.variables]), self._extra_lower])

    @property
    def ubw(self) -> np.ndarray:
        return np.concatenate([np.log([v.upper for v in self.variables]), self._extra_upper])

    @property
    def lbg(self) -> np.ndarray:
        return np.array(self._lbg, dtype=float)

    @property
    def ubg(self) -> np.ndarray:
        return np.array(self._ubg, dtype=float)


def scale(*candidates) -> float:
    """The largest finite, non-zero |candidate|, or 1 when there is none."""
    finite = [abs(c) for c in candidates if c is not None and math.isfinite(c) and c != 0]
    return max(finite) if finite else 1.0
