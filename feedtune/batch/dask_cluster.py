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
"""

from __future__ import annotations

from typing import Callable

from feedtune.batch.job import WORKER_DIED, Outcome, solve

WINDOW = 64


class DaskExecutor:
    """Run tasks ``(index, spec bytes, existing sha256)`` on a Dask cluster."""

    name = "dask"

    def __init__(self, address: str | None = None, workers: int | None = None,
                 job: Callable = solve):
        self.address = address
        self.workers = workers
        self.job = job

    def run(self, tasks: list[tuple[int, bytes, str | None]],
            on_outcome: Callable[[int, Outcome], None]) -> None:
        from distributed import Client, LocalCluster, as_completed
        from distributed.scheduler import KilledWorker

        from feedtune.batch.local import default_workers

        cluster = None
        if self.address is None:
            cluster = LocalCluster(n_workers=self.workers or default_workers(),
                                   threads_per_worker=1, processes=True,
                                   dashboard_address=None)
            client = Client(cluster)
        else:
            client = Client(self.address)
        try:
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
                try:
                    outcome = future.result()
                except KilledWorker:
                    suspects.append(index)
                    outcome = None
                except Exception as exc:  # noqa: BLE001 — e.g. the spec did not pickle
                    outcome = Outcome("error", f"Dask task failed: {type(exc).__name__}: {exc}")
                if outcome is not None:
                    on_outcome(index, outcome)
                future.release()
                submit_next()
            by_index = {task[0]: task for task in tasks}
            for index in suspects:  # again, alone on the cluster: only the culprit dies again
                _, data, existing = by_index[index]
                future = client.submit(self.job, data, existing, pure=False,
                                       key=f"feedtune-spec-{index}-alone")
                try:
                    outcome = future.result()
                except KilledWorker as exc:
                    outcome = Outcome(WORKER_DIED, "the Dask worker running this spec died, "
                                                   f"also when it ran alone ({exc})")
                except Exception as exc:  # noqa: BLE001
                    outcome = Outcome("error", f"Dask task failed: {type(exc).__name__}: {exc}")
                on_outcome(index, outcome)
                future.release()
        finally:
            client.close()
            if cluster is not None:
                cluster.close()
