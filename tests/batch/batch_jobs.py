"""Jobs that misbehave on purpose, for the executors' failure handling.

Module-level, so the executors can pickle them by name into their workers (spawned
workers import this module from the test process's sys.path)."""

from __future__ import annotations

import os
import signal
import sys
import time
from pathlib import Path

from feedtune.batch.job import Outcome, solve

CRASH_MARK = b"crash-me"
SLEEP_MARK = b"sleep-me"


def crashing(data: bytes, existing):
    """Kill the worker (SIGKILL) on a spec whose bytes contain CRASH_MARK; solve the rest."""
    if CRASH_MARK in data:
        os.kill(os.getpid(), signal.SIGKILL)
    return solve(data, existing)


def sleeping(data: bytes, existing):
    """Hang for a minute on a spec whose bytes contain SLEEP_MARK; solve the rest."""
    if SLEEP_MARK in data:
        time.sleep(60)
    return solve(data, existing)


def first_spec_facts(data: bytes, existing):
    """Say what the worker had before this spec's clock started: whether its objects from
    before (the imports, the warm-up's) were out of the garbage collector's scans
    (``gc.freeze``), whether it had loaded the tuner and tuned its warm-up spec, and the
    collector's young-generation threshold."""
    import gc

    frozen = gc.get_freeze_count() > 10_000
    from feedtune.batch import job

    return Outcome("error", f"tuner loaded before the spec: {'feedtune.problem' in sys.modules}"
                            f", warmed up: {job._warmed}; objects frozen before the spec: "
                            f"{frozen}; young-generation threshold: {gc.get_threshold()[0]}")


#: set by a test in its own process; a worker forked from it sees the value, a spawned one
#: imports this module afresh and sees None
PARENT_MARK = None
TERM_MARK = b"term-me"


def parent_mark(data: bytes, existing):
    """Say which PARENT_MARK the worker sees (without solving)."""
    return Outcome("error", f"parent mark: {PARENT_MARK}")


def terminated(data: bytes, existing):
    """Send this worker SIGTERM on a spec whose bytes contain TERM_MARK; solve the rest."""
    if TERM_MARK in data:
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(60)  # a worker that ignored it would hang here, not die
    return solve(data, existing)


def lock_descriptors(data: bytes, existing):
    """Say how many of this worker's file descriptors refer to a batch lock file (Linux:
    /proc/self/fd), without solving."""
    from feedtune.batch.runner import LOCK_NAME

    names = []
    for fd in os.listdir("/proc/self/fd"):
        try:
            names.append(os.readlink(f"/proc/self/fd/{fd}"))
        except OSError:  # the descriptor listdir itself used, closed meanwhile
            pass
    return Outcome("error", f"lock descriptors: {sum(n.endswith(LOCK_NAME) for n in names)}")


def signal_once(flag: Path, signum: int):
    """A function for ``multiprocessing.util.register_after_fork``: in the first worker
    process started after it is registered (the one that creates ``flag``), send that
    process ``signum`` while it starts, before its own code runs; later workers start
    undisturbed."""

    def send(_anchor) -> None:
        try:
            os.close(os.open(flag, os.O_CREAT | os.O_EXCL))
        except FileExistsError:
            return
        os.kill(os.getpid(), signum)

    return send
