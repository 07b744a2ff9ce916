"""Importing this module loads and warms the tuner in this process
(:func:`feedtune.batch.job.warm_up`): the module a forkserver preloads
(:func:`feedtune.batch.dask_cluster.warm_worker_processes`), so that every worker process
forked from that server starts with CasADi, scipy, the metrics and the validator loaded and
the warm-up spec's solver built, as the local executor's workers forked from the batch's
process do, instead of each loading them on its own first spec.
"""

from feedtune.batch.job import warm_up

warm_up()
