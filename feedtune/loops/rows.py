"""An SX Function of one scalar evaluated over a long row by numpy, with CasADi's bits.

CasADi's virtual machine evaluates a mapped SX Function point by point, ≈ 3 ns an
instruction: a scan of 1 601 points of a 155–230-instruction function (min_radius) is
≈ 0.7–1 ms. numpy runs each instruction over the whole row at once. Only operations that
IEEE 754 rounds correctly (+, −, ×, ÷, √, |x|, −x, x², 2x, 1/x) are numpy's: both give the
one correctly rounded double, so the same bits. Every other operation (exp, sin, cos, log,
comparisons, …) is CasADi's own: one call of an SX Function of it over the row
(:class:`~feedtune.loops.frequency.Buffered`), so its bits are CasADi's too (numpy's
SIMD exp differs from glibc's by an ulp in a few per cent of arguments).
"""

from __future__ import annotations

import operator
import threading
from collections import OrderedDict
from functools import lru_cache

from feedtune.lazy import ca, np


def _numpy_operations() -> dict:
    """CasADi operation code → (the correctly rounded numpy ufunc for rows, the same
    operation on float64 scalars, its operands as a function of the instruction's): x² is
    x·x, 2x is x + x, 1/x is 1 ÷ x, each the same double as CasADi's."""
    same, doubled = (lambda a: a), (lambda a: (a[0], a[0]))
    return {ca.OP_ADD: (np.add, operator.add, same),
            ca.OP_SUB: (np.subtract, operator.sub, same),
            ca.OP_MUL: (np.multiply, operator.mul, same),
            ca.OP_DIV: (np.divide, operator.truediv, same),
            ca.OP_NEG: (np.negative, operator.neg, same),
            ca.OP_SQ: (np.multiply, operator.mul, doubled),
            ca.OP_TWICE: (np.add, operator.add, doubled),
            ca.OP_INV: (np.divide, operator.truediv, lambda a: (None, a[0])),
            ca.OP_SQRT: (np.sqrt, np.sqrt, same),
            ca.OP_FABS: (np.fabs, operator.abs, same)}


@lru_cache(maxsize=256)
def _casadi_operation(op: int, arity: int, size: int):
    """CasADi's operation ``op`` of ``arity`` operands at each element of rows of ``size``
    (an SX Function of ``size`` instructions: no call per element, as a map has), called
    through its evaluation buffer (kept per operation and row length)."""
    from feedtune.loops.frequency import Buffered

    args = [ca.SX.sym(f"x{i}", size) for i in range(arity)]
    expr = ca.SX.unary(op, args[0]) if arity == 1 else ca.SX.binary(op, *args)
    return Buffered(ca.Function(f"op{op}_{size}", args, [expr]))


class Row:
    """``fn`` (an SX Function of (x, fixed inputs), one scalar output) at every element of
    a row of x, by numpy's correctly rounded operations and CasADi's others: the bits of
    CasADi's own evaluation of ``fn`` at each element.

    The instructions that do not depend on x (the loop's numbers) run once on float64
    scalars; the others run on rows, each register's row written in place.

    Raises NotImplementedError for a Function that is not SX, or whose first output is not
    one scalar."""

    def __init__(self, fn):
        if not fn.is_a("SXFunction") or fn.nnz_out(0) != 1 or fn.nnz_in(0) != 1:
            raise NotImplementedError("an SX Function of one scalar to one scalar")
        numpy_ops = _numpy_operations()
        self._registers = fn.sz_w()
        self._program = []  # (what, output register, operand registers, on rows)
        on_row = [False] * self._registers  # whether a register holds a row now
        self._output = None
        for k in range(fn.n_instructions()):
            op, out = fn.instruction_id(k), fn.instruction_output(k)
            operands = tuple(fn.instruction_input(k))
            if op == ca.OP_OUTPUT:
                if out[0] == 0:
                    self._output = (operands[0], on_row[operands[0]])
                continue
            if op == ca.OP_INPUT:
                row = operands[0] == 0
                step = ("input", out[0], operands, row)
            elif op == ca.OP_CONST:
                row = False
                step = ("const", out[0], np.float64(fn.instruction_constant(k)), row)
            else:
                row = any(on_row[a] for a in operands)
                if op in numpy_ops:
                    ufunc, scalar, arrange = numpy_ops[op]
                    step = (ufunc if row else scalar, out[0], arrange(operands), row)
                else:
                    step = ((op, len(operands)), out[0], operands, row)
            on_row[out[0]] = row
            self._program.append(step)

    def __call__(self, x, *fixed) -> np.ndarray:
        """``fn`` at each element of the row ``x``, ``fixed`` its other inputs (flat arrays)."""
        x = np.asarray(x, dtype=float).ravel()
        n = x.size
        w = [None] * self._registers  # a float64 scalar or a row
        rows = [None] * self._registers  # each register's own row, written in place
        one = np.float64(1.0)
        with np.errstate(all="ignore"):  # inf and NaN as CasADi makes them, silently
            for what, out, args, row in self._program:
                if what == "input":
                    w[out] = x if row else np.float64(fixed[args[0] - 1][args[1]])
                elif what == "const":
                    w[out] = args
                elif isinstance(what, tuple):  # CasADi's own operation
                    operands = [w[a] for a in args]
                    if row:
                        w[out] = rows[out] = _casadi_operation(*what, n)(
                            *(np.broadcast_to(v, (n,)) for v in operands))[0]
                    else:
                        w[out] = np.float64(_casadi_operation(*what, 1)(*operands)[0][0])
                elif row:
                    if rows[out] is None:
                        rows[out] = np.empty(n)
                    w[out] = what(*[one if a is None else w[a] for a in args], out=rows[out])
                else:
                    w[out] = what(*[one if a is None else w[a] for a in args])
        register, row = self._output
        return w[register].copy() if row else np.full(n, w[register], dtype=float)


#: rows kept (an LRU), by the caller's key (a name and a loop structure)
_ROWS_SIZE = 64
_rows: OrderedDict[tuple, Row | None] = OrderedDict()
_rows_lock = threading.Lock()  # a Dask worker runs specs in threads


def row_of(key: tuple, fn) -> Row | None:
    """The :class:`Row` of ``fn`` kept under ``key`` (built at the first request; None for a
    Function it cannot take). ``key`` names ``fn`` for every loop of a structure (as
    :func:`feedtune.loops.frequency.replayed` keys its Functions), so the program is read
    from CasADi once per structure."""
    with _rows_lock:
        if key in _rows:
            _rows.move_to_end(key)
            return _rows[key]
    try:
        row = Row(fn)
    except NotImplementedError:
        row = None
    with _rows_lock:
        _rows[key] = row
        while len(_rows) > _ROWS_SIZE:
            _rows.popitem(last=False)
    return row
