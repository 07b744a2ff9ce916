"""CasADi Functions called with numbers through their evaluation buffers.

A Function called from Python with numpy arrays converts each argument to a DM and each
result back (CasADi's overloaded argument conversion: ≈ 20 µs an argument, ≈ 7 µs a
result), which costs more than evaluating the tuner's small Functions. A Function's
evaluation buffer (``Function.buffer``) reads its arguments from, and writes its results
into, numpy arrays bound once; the evaluation is the same, so the numbers are the same
bits. Measured (benchmarks/batch_starts.py, branch h-bst4, load 11): a batch spec's six NLP
checks 1.08 → 0.42 ms of CPU, its three IPOPT solves 17.27 → 17.00 ms (IPOPT's own work
is the rest), the same iterates, multipliers and statistics.

A buffer is one evaluation's memory: each thread has its own (a Dask worker runs specs in
threads, and the solver and the Functions of a structure are shared by every problem of
it, feedtune.tuner.cache).
"""

from __future__ import annotations

import threading
import weakref

import numpy as np

from feedtune.buffers import ThreadBuffers

#: each Function's numeric callers, by ``check``: kept while the Function is (its proxy
#: object, e.g. a cached solver or a structure's Functions), never beyond
_calls: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_calls_lock = threading.Lock()


def numeric(function, check: bool = True) -> "NumericCall":
    """The :class:`NumericCall` of ``function``, made once for it (the set-up reads every
    input's and output's sparsity: ≈ 0.1 ms) and dropped with it."""
    with _calls_lock:
        calls = _calls.setdefault(function, {})
        if check not in calls:
            calls[check] = NumericCall(function, check)
        return calls[check]


class NumericCall:
    """``function`` evaluated at numbers: :meth:`__call__` takes each input's values (any
    array-like of its number of entries, column-major for a matrix) and
    returns every output as :meth:`casadi.DM.full` would, a dense 2-D array with zeros
    where the output's sparsity has none. An input left out (or None) takes the
    Function's default (``default_in``: e.g. an nlpsol's multipliers start at 0), as in a
    call with DMs. Every input must be dense.

    ``check``: raise RuntimeError when the evaluation reports a failure, as a call with
    DMs does; an nlpsol built with ``error_on_fail`` False reports its solver's failure in
    :meth:`stats` instead, and is called with ``check=False``.
    """

    def __init__(self, function, check: bool = True):
        self._function = weakref.ref(function)  # not kept alive by its caller (numeric)
        self.check = check
        self.name, self.inputs, self.names = (function.name(), function.name_in(),
                                              function.name_out())
        for i in range(function.n_in()):
            if not function.sparsity_in(i).is_dense():
                raise ValueError(f"{function.name()}: input {i} is not dense")
        self._defaults = [function.default_in(i) for i in range(function.n_in())]
        self._shapes = []  # (shape, (rows, columns) of the nonzeros, or None when dense)
        for i in range(function.n_out()):
            sparsity = function.sparsity_out(i)
            shape = (sparsity.size1(), sparsity.size2())
            dense = sparsity.nnz() == shape[0] * shape[1]
            # int: an output without nonzeros (a Jacobian of rows that do not depend on
            # the variables) has empty index lists, which numpy would make float
            self._shapes.append((shape, None if dense else (
                np.array(sparsity.row(), dtype=int), np.array(sparsity.get_col(), dtype=int))))
        self._buffers = ThreadBuffers([function.nnz_out(i) for i in range(function.n_out())])

    @property
    def function(self):
        """The Function (None once it is gone)."""
        return self._function()

    def _bound(self) -> tuple:
        """(buffer, evaluate, argument arrays, result arrays) of this thread."""
        return self._buffers.bound(self._alive)

    def _alive(self):
        """The Function, to bind a thread's buffer to."""
        fn = self.function
        if fn is None:
            raise RuntimeError(f"{self.name}: the Function no longer exists")
        return fn

    def __call__(self, *inputs) -> np.ndarray | list[np.ndarray]:
        """The outputs at ``inputs`` (by position), as a Function called with DMs gives
        them: the one output alone, else a list."""
        out = self.outputs(*inputs)
        return out[0] if len(out) == 1 else out

    def outputs(self, *inputs) -> list[np.ndarray]:
        """Every output at ``inputs`` (by position), in a list."""
        buffer, evaluate, args, results = self._bound()
        for i, target in enumerate(args):
            value = inputs[i] if i < len(inputs) else None
            if value is None:
                target[:] = self._defaults[i]
            else:
                target[:] = np.asarray(value, dtype=float).ravel(order="F")
        try:
            evaluate()
        except SystemError as exc:
            # CasADi's interrupt check (an nlpsol's iterations) ran a Python signal handler
            # and caught its KeyboardInterrupt: the solve ends NonIpopt_Exception_Thrown. A
            # call with DMs clears the exception and returns; the buffer's call leaves it
            # set, which Python reports as this SystemError: returned as the DM call does
            if not isinstance(exc.__cause__, KeyboardInterrupt):
                raise
        if self.check and buffer.ret() != 0:
            raise RuntimeError(f"evaluation of {self.name} failed")
        out = []
        for values, (shape, where) in zip(results, self._shapes):
            if where is None:
                out.append(values.reshape(shape, order="F").copy())
            else:
                full = np.zeros(shape)
                full[where] = values
                out.append(full)
        return out

    def nonzeros(self, *inputs) -> list[np.ndarray]:
        """Every output's nonzeros at ``inputs`` (by position, each a flat array of the
        input's entries, every input given): this thread's result arrays themselves, not
        copies, so valid until its next call; an output with structural zeros has fewer
        entries than :meth:`outputs` gives it (:meth:`dense` says which)."""
        buffer, evaluate, args, results = self._bound()
        for target, value in zip(args, inputs):
            target[:] = value
        evaluate()
        if self.check and buffer.ret() != 0:
            raise RuntimeError(f"evaluation of {self.name} failed")
        return results

    def dense(self, index: int) -> bool:
        """Output ``index`` has no structural zeros: its :meth:`nonzeros` are its entries
        (column-major)."""
        return self._shapes[index][1] is None

    def named(self, **inputs) -> dict[str, np.ndarray]:
        """:meth:`__call__` with the inputs by name (those left out: their defaults), the
        outputs by name."""
        unknown = set(inputs) - set(self.inputs)
        if unknown:
            raise ValueError(f"{self.name} has no input {sorted(unknown)}")
        return dict(zip(self.names, self.outputs(*[inputs.get(name) for name in self.inputs])))

    def stats(self) -> dict:
        """The statistics of this thread's last evaluation (an nlpsol's: ``iter_count``,
        ``return_status``, ...)."""
        return self._bound()[0].stats()
