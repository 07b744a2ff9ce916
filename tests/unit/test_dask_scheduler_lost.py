"""feedtune.batch.dask_cluster.scheduler_lost: a result whose fetch ends in
``CommClosedError`` is the scheduler's loss only when the client leaves its ``running``
state (tests/batch/test_batch_cli.py's lost-scheduler test kills the scheduler mid-run;
in ≈ 1 of 10 runs a fetch in flight got ``CommClosedError`` and its spec was charged
``error`` instead of staying ``not_run``)."""

from __future__ import annotations

import threading
import time

from feedtune.batch.dask_cluster import scheduler_lost


class _Client:
    """A stand-in with the one attribute read: Dask's ``Client.status``."""

    def __init__(self, status: str):
        self.status = status


def test_a_client_that_left_running_has_lost_its_scheduler():
    for status in ("connecting", "closing", "closed"):
        assert scheduler_lost(_Client(status), wait=0.0)


def test_a_client_still_running_after_the_wait_has_its_scheduler():
    client = _Client("running")
    started = time.monotonic()
    assert not scheduler_lost(client, wait=0.05)
    assert time.monotonic() - started >= 0.05  # it waited for the client to notice


def test_a_loss_noticed_during_the_wait_counts():
    client = _Client("running")
    timer = threading.Timer(0.05, setattr, (client, "status", "connecting"))
    timer.start()
    try:
        assert scheduler_lost(client, wait=5.0)
    finally:
        timer.cancel()
