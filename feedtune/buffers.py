"""A CasADi Function's evaluation buffer bound to numpy arrays, one binding per thread.

``Function.buffer`` reads a Function's arguments from, and writes its results into, memory
bound once: the same evaluation as a call with DMs, so the same bits, without CasADi's
argument conversions (≈ 20 µs an argument, ≈ 7 µs a result). A buffer is one evaluation's
memory, so each thread binds its own (a Dask worker runs specs in threads, and a
structure's Functions are shared by every problem of it). Used by the loops' numeric rows
(:class:`feedtune.loops.frequency.Buffered`) and the tuner's calls
(:class:`feedtune.tuner.calls.NumericCall`).
"""

from __future__ import annotations

import threading
from typing import Callable, Sequence

from feedtune.lazy import np


class ThreadBuffers:
    """Per-thread bindings of a Function's evaluation buffer: arguments of each input's
    number of nonzeros, results of ``result_sizes`` entries (the outputs' nonzeros, or
    their whole size for an output the buffer leaves at 0 where it has no nonzeros)."""

    def __init__(self, result_sizes: Sequence[int]):
        self._result_sizes = list(result_sizes)
        self._local = threading.local()

    def bound(self, function: Callable[[], object]) -> tuple:
        """This thread's (buffer, evaluate, argument arrays, result arrays), bound at its
        first use to the Function that ``function()`` returns."""
        bound = getattr(self._local, "bound", None)
        if bound is None:
            fn = function()
            buffer, evaluate = fn.buffer()
            args = [np.zeros(fn.nnz_in(i)) for i in range(fn.n_in())]
            results = [np.zeros(size) for size in self._result_sizes]
            for i, a in enumerate(args):
                buffer.set_arg(i, memoryview(a))
            for i, r in enumerate(results):
                buffer.set_res(i, memoryview(r))
            bound = self._local.bound = (buffer, evaluate, args, results)
        return bound
