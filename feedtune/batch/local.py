"""The default executor: worker processes on this machine, one per core, no server.

Why not ``concurrent.futures`` or joblib: when a worker process dies (a segfault in a
solver, the kernel's OOM killer), both mark the whole pool broken and cannot say which
spec killed it. Here each worker tells the parent which spec it starts, so a death is
charged to that spec alone (status ``worker_died``), the rest of its chunk goes back to
the queue and a new worker takes over. The same bookkeeping enforces ``timeout``: a spec
that runs longer has its worker killed (status ``timeout``).

Work goes out in chunks: one spec at first, then as many as take about
``CHUNK_SECONDS`` at the mean time per spec measured so far (never more than a fair share
of what is left, so the last chunks still spread over every worker). Each worker is a
long-lived process, so the solvers it builds are reused for every later spec of the same
structure (see ``feedtune.tuner.cache``).

Workers are forked from this process where that is safe (:func:`start_method`): the
tuner is imported and warmed up once, here (:func:`feedtune.batch.job.warm_up`), and every
worker starts with it loaded (and with any solver this process has already built),
instead of each spawned worker importing CasADi, scipy and the metrics on its own and
loading the rest on its first spec (≈ 0.9 s + 0.8 s of CPU per worker, issue 15).
"""

from __future__ import annotations

import gc
import multiprocessing
import multiprocessing.resource_tracker
import os
import signal
import sys
import threading
import time
from collections import deque
from dataclasses import dataclass, field
from multiprocessing.connection import wait
from typing import Callable

from feedtune.batch.job import TIMEOUT, WORKER_DIED, Outcome, solve

#: a chunk should keep a worker busy about this long [s]
CHUNK_SECONDS = 0.5
#: how long the parent waits for messages before checking time limits [s]
POLL_SECONDS = 0.2
#: what the batch's process handles itself (Ctrl-C, and SIGTERM: how CI cancels)
STOP_SIGNALS = frozenset({signal.SIGINT, signal.SIGTERM})
#: a worker's young-generation threshold (``gc.set_threshold``'s first; CPython's is 700):
#: a batch spec leaves ≈ 200 objects in reference cycles (CasADi wrappers, closures), and
#: at 700 a worker ran ≈ 0.7 young collections a spec, each walking the young objects and
#: every tenth the middle generation again; at 5000 under 0.1 a spec, the same garbage
#: freed a few specs later, ≈ 1 MB more resident: the collections' time 0.45–1.2 → 0.25–0.36
#: ms a spec (benchmarks/README.md, "Branch h-bval6")
WORKER_GC_THRESHOLD = 5000


def default_workers() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def start_method() -> str:
    """``fork`` where a worker can start as a copy of this process, else ``spawn``.

    Fork needs an operating system that has it and that is not macOS (where system
    libraries may not survive a fork), and this process running no other Python thread: a
    lock another thread holds at the fork (a logging handler's, an import's) would stay
    held in the worker forever. A caller's thread, a Dask client or a progress thread
    therefore means spawn. Threads below Python are OpenBLAS's pools, which shut down
    before a fork and start again in the child; with one BLAS thread, as the ``feedtune``
    command sets it, there are none (measured: one OS thread after a tuning).
    """
    if ("fork" in multiprocessing.get_all_start_methods() and sys.platform != "darwin"
            and threading.active_count() == 1):
        return "fork"
    return "spawn"


def _die_with_parent() -> None:
    """Ask Linux to SIGKILL this process when its parent dies (no orphans after a kill),
    and end it now if the parent died before it asked: a worker whose batch was killed as
    it started waited for work forever (its connection to the batch never reaches its end:
    a forked worker holds the batch's end of it too)."""
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass
    if os.getppid() != multiprocessing.parent_process().pid:
        os._exit(1)


def _worker_main(connection, job: Callable, mask: frozenset) -> None:
    """A worker: run ``job`` on each spec of each chunk the parent sends, reporting each
    spec's start and end.

    It starts with STOP_SIGNALS blocked (:meth:`LocalExecutor._spawn`) and unblocks them
    (back to ``mask``, the parent's signal mask before the start) only once its own
    handlers are set: a forked worker is a copy of the batch's process, whose handlers turn
    these signals into a KeyboardInterrupt, and one arriving before the worker's own
    handlers were set (a Ctrl-C to the terminal's process group, a CI's SIGTERM to every
    process) printed multiprocessing's traceback of the worker's start instead of being
    ignored or ending it.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent handles Ctrl-C
    # a forked worker inherits the parent's handler (the batch defers SIGTERM while it
    # writes a result): here SIGTERM ends the process, as in a spawned one; one that came
    # meanwhile does so now
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_SETMASK, mask)
    _die_with_parent()
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)  # solver chatter must not reach the batch's stdout
    os.close(devnull)
    # load and warm the tuner (CasADi: 1.5 s, the first tuning's IPOPT and the
    # validator another 0.5 s; more under load) before any spec's clock starts, so
    # --timeout measures the spec, not this worker's start (a forked worker has it already)
    from feedtune.batch.job import warm_up

    warm_up()
    # what the worker holds before its first spec (imports, the warm-up's solvers: ≈ 74 000
    # objects) out of the garbage collector's scans: its full collections walked them all
    # and, in a forked worker, wrote to pages it shares with the batch (copy on write):
    # 0.44 → 0.19 ms of collections a spec, 76 → 48 page faults (benchmarks/README.md,
    # "Branch h-bx1"). The spec's own objects are collected as before, in fewer young
    # collections (WORKER_GC_THRESHOLD).
    gc.freeze()
    gc.set_threshold(WORKER_GC_THRESHOLD, *gc.get_threshold()[1:])
    while True:
        try:
            chunk = connection.recv()
        except EOFError:
            return
        if chunk is None:
            return
        for index, data, existing in chunk:
            connection.send(("start", index))
            connection.send(("done", index, job(data, existing)))


@dataclass
class _Worker:
    process: multiprocessing.Process
    connection: object
    chunk: deque = field(default_factory=deque)  # tasks sent and not yet done
    current: int | None = None  # index of the spec being solved
    since: float = 0.0  # when it started


class LocalExecutor:
    """Run tasks ``(index, spec bytes, existing sha256)`` on ``workers`` processes.

    ``job(data, existing_sha256) -> Outcome`` is :func:`feedtune.batch.job.solve` unless a
    test gives another module-level function (a spawned worker imports it by name).
    ``start`` is the multiprocessing start method (``fork`` or ``spawn``); by default
    :func:`start_method` chooses when the workers start.
    """

    name = "local"

    def __init__(self, workers: int | None = None, timeout: float | None = None,
                 job: Callable = solve, start: str | None = None):
        self.workers = workers or default_workers()
        self.timeout = timeout
        self.job = job
        self.start = start
        self._context = None

    def run(self, tasks: list[tuple[int, bytes, str | None]],
            on_outcome: Callable[[int, Outcome], None]) -> None:
        """Call ``on_outcome(index, outcome)`` once per task, in completion order."""
        queue = deque(tasks)
        workers: list[_Worker] = []
        durations: list[float] = []
        method = self.start or start_method()
        if method == "fork" and queue:
            from feedtune.batch.job import warm_up

            warm_up()  # once here, not once per worker: the tuner, IPOPT, the validator
        self._context = multiprocessing.get_context(method)
        try:
            for _ in range(min(self.workers, len(queue))):
                self._spawn(workers)
            for worker in workers:
                self._feed(worker, queue, durations)
            while any(w.chunk for w in workers) or queue:
                ready = wait([w.connection for w in workers] + [w.process.sentinel for w in workers],
                             timeout=POLL_SECONDS)
                for worker in list(workers):
                    if worker.connection in ready or worker.process.sentinel in ready:
                        self._receive(worker, on_outcome, durations)
                    if not worker.process.is_alive():
                        self._receive(worker, on_outcome, durations)  # what it sent before dying
                        self._lost(worker, queue, on_outcome, WORKER_DIED,
                                   _death_message(worker.process.exitcode))
                        worker = self._spawn(workers, replacing=worker)
                    elif (self.timeout is not None and worker.current is not None
                          and time.perf_counter() - worker.since > self.timeout):
                        worker.process.kill()
                        worker.process.join()
                        self._lost(worker, queue, on_outcome, TIMEOUT,
                                   f"took longer than the batch's time limit of {self.timeout:g} s "
                                   "per spec; its worker was stopped")
                        worker = self._spawn(workers, replacing=worker)
                    if not worker.chunk:
                        self._feed(worker, queue, durations)
        finally:
            for worker in workers:
                try:
                    worker.connection.send(None)
                except (OSError, ValueError):
                    pass
            for worker in workers:
                worker.process.join(timeout=5)
                if worker.process.is_alive():
                    worker.process.kill()
                    worker.process.join()

    def _spawn(self, workers: list[_Worker], replacing: _Worker | None = None) -> _Worker:
        """Start a worker and put it in ``workers`` (in ``replacing``'s place, if given).

        STOP_SIGNALS are blocked from before the fork until the worker is in ``workers``:
        a Ctrl-C or SIGTERM landing between the two raised its KeyboardInterrupt here with
        the new worker in no list, so :meth:`run` never stopped it, and at the batch's exit
        multiprocessing sent it SIGTERM, which a worker still starting (forked with this
        process's handlers) turned into a traceback on stderr (the flaky
        ``test_a_signal_early_in_the_batch_is_exit_130_without_a_traceback[sigterm-0.6]``).
        The signal is handled once the worker is listed; the worker unblocks them itself
        (:func:`_worker_main`).
        """
        if self._context.get_start_method() != "fork":
            # multiprocessing starts its resource tracker with the first spawned process
            # and unblocks these signals after that, whatever was blocked before: first
            multiprocessing.resource_tracker.ensure_running()
        mask = signal.pthread_sigmask(signal.SIG_BLOCK, STOP_SIGNALS)
        try:
            parent, child = self._context.Pipe()
            process = self._context.Process(target=_worker_main,
                                            args=(child, self.job, frozenset(mask)),
                                            daemon=True, name="feedtune-batch-worker")
            process.start()
            child.close()
            worker = _Worker(process, parent)
            if replacing is None:
                workers.append(worker)
            else:
                workers[workers.index(replacing)] = worker
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        return worker

    def _feed(self, worker: _Worker, queue: deque, durations: list[float]) -> None:
        if not queue:
            return
        size = self._chunk_size(len(queue), durations)
        chunk = [queue.popleft() for _ in range(min(size, len(queue)))]
        worker.chunk.extend(chunk)
        try:
            worker.connection.send(chunk)
        except (OSError, ValueError):  # died meanwhile: the sentinel tells, the chunk is requeued
            pass

    def _chunk_size(self, remaining: int, durations: list[float]) -> int:
        if not durations:
            return 1
        mean = sum(durations[-200:]) / len(durations[-200:])
        wanted = max(1, round(CHUNK_SECONDS / max(mean, 1e-6)))
        fair = max(1, remaining // (2 * self.workers))
        return min(wanted, fair)

    def _receive(self, worker: _Worker, on_outcome, durations: list[float]) -> None:
        while worker.connection.poll():
            try:
                message = worker.connection.recv()
            except (EOFError, OSError):  # the worker is gone; the main loop sees its sentinel
                return
            if message[0] == "start":
                worker.current, worker.since = message[1], time.perf_counter()
            elif message[0] == "done":
                _, index, outcome = message
                worker.chunk.popleft()
                worker.current = None
                durations.append(outcome.time)
                on_outcome(index, outcome)

    def _lost(self, worker: _Worker, queue: deque, on_outcome, status: str, message: str) -> None:
        """The worker is gone: charge its current spec, put the rest of its chunk back."""
        if worker.current is not None:
            worker.chunk.popleft()
            on_outcome(worker.current, Outcome(status, message,
                                               time=time.perf_counter() - worker.since))
        queue.extendleft(reversed(worker.chunk))
        worker.chunk.clear()
        worker.current = None
        worker.connection.close()


def _death_message(exitcode: int | None) -> str:
    if exitcode is not None and exitcode < 0:
        try:
            name = signal.Signals(-exitcode).name
        except ValueError:
            name = f"signal {-exitcode}"
        return f"the worker process solving this spec was killed by {name}"
    return f"the worker process solving this spec exited unexpectedly (exit code {exitcode})"
