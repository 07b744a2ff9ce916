"""The Dask executor: the same specs on a dask.distributed cluster.

With an address it connects to a running scheduler; without one it starts a local cluster
(one single-threaded worker process per core). Each spec is one task calling
:func:`feedtune.batch.job.solve`, the function the local executor runs, so the results
are the same bytes. A task whose worker dies is retried by Dask on another worker; after
Dask's ``allowed-failures`` deaths Dask gives up on it, and on every task that was queued
on the same worker. Those suspects run again at the end, one at a time, so only a spec
that kills its worker when alone is charged ``worker_died``. Workers keep their solver
cache between tasks, as local workers do. At most ``WINDOW`` tasks per worker are in
flight, so a batch of a million specs does not sit in the scheduler's memory at once.

A local cluster's worker processes are forked from a server that has loaded and warmed the
tuner once (:func:`warm_worker_processes`), not started as fresh interpreters that each
load it again.

A cluster that cannot be used stops the batch with :class:`~feedtune.batch.runner.ExecutorError`
(exit status 2), keeping every result that finished: no connection to the scheduler, or no
worker, within ``worker_timeout``; or the scheduler lost mid-run (Dask then cancels every
task in flight: those specs stay ``not_run`` for a rerun, not ``error``; so does a finished
result whose fetch the loss cut off, :func:`scheduler_lost`).
"""

from __future__ import annotations

import contextlib
import logging
import multiprocessing
import sys
import time
from concurrent.futures import CancelledError
from typing import Callable

from feedtune.batch.job import WORKER_DIED, Outcome, solve
from feedtune.batch.runner import ExecutorError
from feedtune.schema.status import ERROR

WINDOW = 64
#: what the local cluster's forkserver imports before it forks a worker (the second warms
#: the tuner up on import)
PRELOAD = ("distributed", "feedtune.batch.warm")
#: default wait for the scheduler's connection and its first worker [s]
WORKER_TIMEOUT = 60.0
#: how long a failed fetch waits for the client to notice a lost scheduler [s] (a killed
#: scheduler's connection closes at once; the client's state follows in milliseconds)
SCHEDULER_LOSS_WAIT = 2.0
#: Dask's ``Client.status`` while it is connected to its scheduler (Dask's word, not one of
#: feedtune's statuses, feedtune/schema/status.py)
DASK_CLIENT_RUNNING = "running"


def scheduler_lost(client, wait: float = SCHEDULER_LOSS_WAIT) -> bool:
    """Whether ``client`` has lost its scheduler, given ``wait`` [s] to notice: a result
    whose fetch ends in ``CommClosedError`` is the scheduler's loss when the client leaves
    its ``running`` state (it reconnects or closes), else a worker's (measured: with the
    scheduler killed as a batch fetched a result, 1 of ≈ 10 runs got that error instead of
    ``CancelledError``, and the spec was charged ``error``)."""
    deadline = time.monotonic() + wait
    while client.status == DASK_CLIENT_RUNNING:
        if time.monotonic() >= deadline:
            return False
        time.sleep(0.01)
    return True


@contextlib.contextmanager
def warm_worker_processes():
    """Meanwhile, the worker processes of a local Dask cluster (and those its nannies start
    again after a death) are forked from multiprocessing's forkserver, which has imported
    PRELOAD once, i.e. distributed, the tuner and the validator, and tuned
    :data:`~feedtune.batch.job.WARM_UP_SPEC` (:mod:`feedtune.batch.warm`), instead of
    being fresh interpreters (Dask's default, spawn) that each import them and build their
    first spec's solver on their own: ≈ 3.9 s → 0.5 s of CPU a worker after the server's
    ≈ 3 s once (two workers, 3 specs, load 9; benchmarks/README.md "Branch h-tbat").

    The server is forked from no thread-running process (it is a fresh interpreter of its
    own), so this is safe where forking the batch's process is not (the Dask client runs
    threads). Only where the local executor would fork (:func:`~feedtune.batch.local.
    start_method`: Linux); elsewhere Dask's own start is left alone.
    """
    if "forkserver" not in multiprocessing.get_all_start_methods() or sys.platform == "darwin":
        yield
        return
    import dask
    from distributed.utils import get_mp_context

    with dask.config.set({"distributed.worker.multiprocessing-method": "forkserver"}):
        # distributed sets its own preload list at its first call in a process, and never
        # again: after that call, this one is the server's (when it starts, at the first
        # worker; a server already running keeps its own)
        get_mp_context().set_forkserver_preload(list(PRELOAD))
        yield


class DaskExecutor:
    """Run tasks ``(index, spec bytes, existing sha256)`` on a Dask cluster.

    ``address``: a running scheduler's, or None for a local cluster of ``workers``
    processes; ``worker_timeout`` [s]: how long to wait for the connection and for a first
    worker before giving up (:class:`~feedtune.batch.runner.ExecutorError`).
    """

    name = "dask"

    def __init__(self, address: str | None = None, workers: int | None = None,
                 job: Callable = solve, worker_timeout: float = WORKER_TIMEOUT):
        self.address = address
        self.workers = workers
        self.job = job
        self.worker_timeout = worker_timeout

    def run(self, tasks: list[tuple[int, bytes, str | None]],
            on_outcome: Callable[[int, Outcome], None]) -> None:
        from distributed import Client, LocalCluster

        from feedtune.batch.local import default_workers

        where = self.address or "the local Dask cluster"
        # its "failed to reconnect" log would be a second message beside our ExecutorError
        client_log = logging.getLogger("distributed.client")
        client_level = client_log.level
        client_log.setLevel(logging.CRITICAL)
        cluster = client = None
        local = contextlib.ExitStack()
        try:
            if self.address is None:
                local.enter_context(warm_worker_processes())
                cluster = LocalCluster(n_workers=self.workers or default_workers(),
                                       threads_per_worker=1, processes=True,
                                       dashboard_address=None)
                client = Client(cluster)
            else:
                try:
                    client = Client(self.address, timeout=self.worker_timeout)
                except OSError as exc:
                    raise ExecutorError(f"cannot connect to the Dask scheduler at {where}: "
                                        f"{exc}") from None
            try:
                client.wait_for_workers(1, timeout=self.worker_timeout)
            except TimeoutError:
                raise ExecutorError(f"no Dask workers connected to {where} within "
                                    f"{self.worker_timeout:g} s") from None
            self._run(client, tasks, on_outcome, where)
        finally:
            if client is not None:
                client.close()
            if cluster is not None:
                cluster.close()
            local.close()
            client_log.setLevel(client_level)

    def _run(self, client, tasks, on_outcome, where: str) -> None:
        """Submit ``tasks`` in a window, pass each outcome on; suspects of a death again."""
        from distributed import as_completed
        from distributed.comm.core import CommClosedError
        from distributed.scheduler import KilledWorker

        def result(future) -> Outcome | None:
            """The outcome, or None when the task's worker died (KilledWorker) or its
            finished result could not be fetched while the scheduler stays."""
            lost = ExecutorError(f"lost the Dask scheduler at {where} mid-run; the results "
                                 "that finished are kept, rerun to finish")
            try:
                return future.result()
            except KilledWorker:
                return None
            except CancelledError:  # we cancel nothing: the scheduler is gone
                raise lost from None
            except CommClosedError:  # not the spec's failure: the cluster's connection
                if scheduler_lost(client):
                    raise lost from None
                return None  # its worker went away: run it again, as a suspect
            except Exception as exc:  # noqa: BLE001 — e.g. the spec did not pickle
                return Outcome(ERROR, f"Dask task failed: {type(exc).__name__}: {exc}")

        width = max(1, len(client.scheduler_info()["workers"])) * WINDOW
        pending = iter(tasks)
        futures = as_completed()
        submitted = {}

        def submit_next() -> bool:
            task = next(pending, None)
            if task is None:
                return False
            index, data, existing = task
            future = client.submit(self.job, data, existing, pure=False,
                                   key=f"feedtune-spec-{index}")
            submitted[future.key] = index
            futures.add(future)
            return True

        for _ in range(width):
            if not submit_next():
                break
        suspects = []  # tasks on a worker that died: the culprit, or only beside it
        for future in futures:
            index = submitted.pop(future.key)
            outcome = result(future)
            if outcome is None:
                suspects.append(index)
            else:
                on_outcome(index, outcome)
            future.release()
            submit_next()
        by_index = {task[0]: task for task in tasks}
        for index in suspects:  # again, alone on the cluster: only the culprit dies again
            _, data, existing = by_index[index]
            future = client.submit(self.job, data, existing, pure=False,
                                   key=f"feedtune-spec-{index}-alone")
            outcome = result(future)
            on_outcome(index, outcome or Outcome(
                WORKER_DIED, "the Dask worker running this spec died, also when it ran "
                             "alone"))
            future.release()
