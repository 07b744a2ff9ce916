"""Batch tuning: many specs, in parallel, resumable (``feedtune batch``).

:func:`~feedtune.batch.runner.run_batch` reads the inputs and writes the results;
executors run :func:`feedtune.batch.job.solve` per spec: on local processes
(:class:`~feedtune.batch.local.LocalExecutor`, the default) or on a Dask cluster
(:class:`~feedtune.batch.dask_cluster.DaskExecutor`).
"""
