"""A batch from start to end: read the inputs, lock the output directory, hand the specs
to an executor, write each result as it arrives, and the summary at the end.

Files in the output directory, each written atomically (``feedtune.schema.files``):
``NAME.json`` per spec with a result (named after the spec, see
:mod:`feedtune.batch.inputs`), and ``summary.json`` (one row per spec, input order),
rewritten every ``SUMMARY_SECONDS`` while the batch runs, so even a killed batch leaves a
readable one. A rerun skips every spec whose result file holds the same canonical-spec
hash and feedtune version (a ``resumed`` row) and solves the rest.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import json
import os
import signal
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from feedtune import __version__
from feedtune.batch.inputs import InputError, Item, check_output_apart, load_items
from feedtune.batch.job import INVALID, RESUMED, Outcome, summary_fields
from feedtune.batch.reports import BASELINE_RTOL, compare, judge, summary_document
from feedtune.schema.files import remove_stale_temporaries, write_atomic
from feedtune.schema.status import ERROR, NOT_RUN

SUMMARY_SECONDS = 10.0
LOCK_NAME = ".feedtune-batch.lock"


class ExecutorError(RuntimeError):
    """The executor itself cannot go on (e.g. no Dask workers, the scheduler lost): the
    batch stops, keeping what finished (exit status 2)."""


@dataclass
class BatchOutcome:
    document: dict  # what summary.json holds
    wall: float  # [s]
    interrupted: bool
    executor_error: str | None = None  # why the executor stopped the batch, if it did


def existing_sha256(path: Path) -> str | None:
    """The canonical-spec hash of the result at ``path`` if it is this feedtune's, else None."""
    try:
        with open(path, "rb") as handle:
            provenance = json.load(handle)["provenance"]
    except (OSError, ValueError, KeyError, TypeError):
        return None
    if not isinstance(provenance, dict) or provenance.get("feedtune") != __version__:
        return None
    sha = provenance.get("spec_sha256")
    return sha if isinstance(sha, str) else None


#: descriptors of the batch locks this process holds; a process forked meanwhile (a batch
#: worker) must not hold them too, or a killed batch's lock would stay held until its
#: workers had died as well (a rerun right after a SIGKILL was refused: "another feedtune
#: batch is writing to this directory")
_held_locks: set[int] = set()


def _drop_held_locks() -> None:
    """In a forked child: point each held lock's descriptor at /dev/null (the lock's open
    file stays the parent's alone; the descriptor stays valid for whatever closes it)."""
    if not _held_locks:
        return
    devnull = os.open(os.devnull, os.O_RDONLY)
    try:
        for fd in _held_locks:
            os.dup2(devnull, fd, inheritable=False)
    finally:
        os.close(devnull)
    _held_locks.clear()


os.register_at_fork(after_in_child=_drop_held_locks)


@contextlib.contextmanager
def locked(directory: Path):
    """Hold ``directory``'s batch lock (released by the kernel even after SIGKILL, as soon
    as this process is gone: forked workers do not hold it).

    The lock file is never opened through a symlink, which could name a file outside
    ``directory`` to create.
    """
    path = directory / LOCK_NAME
    try:
        fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW, 0o666)
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise InputError(f"{path}: is a symbolic link; the batch lock must be a plain "
                             "file (remove the link)") from None
        raise
    handle = os.fdopen(fd, "a+")
    try:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise InputError(f"{directory}: another feedtune batch is writing to this "
                             "directory") from None
        _held_locks.add(fd)
        yield
    finally:
        _held_locks.discard(fd)
        handle.close()


@contextlib.contextmanager
def signals_deferred():
    """Hold Ctrl-C and SIGTERM back meanwhile and raise them again at the end (to whatever
    handled them before), so an interrupt lands between two specs' bookkeeping, never inside
    one: a result file written and its summary row saying so. Signals are the main
    thread's: elsewhere (a library caller's thread) nothing is held."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []
    previous = {signum: signal.signal(signum, lambda signum, frame: caught.append(signum))
                for signum in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        for signum in dict.fromkeys(caught):
            signal.raise_signal(signum)


def prepare_output(out: Path) -> None:
    if out.exists() and not out.is_dir():
        raise InputError(f"{out}: exists and is not a directory")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"{out}: cannot create the output directory: {exc.strerror or exc}") from None
    if not os.access(out, os.W_OK | os.X_OK):
        raise InputError(f"{out}: output directory is not writable")


def _base_row(item: Item) -> dict:
    return {"id": item.stem, "name": item.name, "input": item.label, "path": item.path,
            "line": item.line, "result": None, "status": NOT_RUN, "ok": False,
            "reason": NOT_RUN, "success": False, "constraints_satisfied": None,
            "validation_ok": None, "validation_failures": [], "optimum_unique": None, "notes": [],
            "objective": None, "tuned": {},
            "message": "not run (the batch stopped before it)", "errors": [], "time": 0.0,
            "resumed": False, "spec_sha256": None}


def run_batch(inputs: list[str], out: Path, executor, *, baseline: dict | None = None,
              baseline_rtol: float = BASELINE_RTOL, on_row: Callable[[dict], None] | None = None,
              header: dict | None = None) -> BatchOutcome:
    """Solve every spec named by ``inputs`` into ``out``.

    ``executor`` has ``run(tasks, on_outcome)`` (:class:`~feedtune.batch.local.LocalExecutor`
    or :class:`~feedtune.batch.dask_cluster.DaskExecutor`), which raises
    :class:`ExecutorError` when it cannot go on; ``baseline`` maps result ids
    to an earlier batch's rows; ``on_row(row)`` is called as each spec finishes.

    Raises
    ------
    InputError
        When the inputs or the output directory cannot be used, or ``out`` is where the
        inputs are read from.
    """
    started = time.perf_counter()
    items = load_items(inputs)
    if not items:
        raise InputError("the inputs hold no specs")
    check_output_apart(inputs, out)
    prepare_output(out)
    header = {"feedtune": __version__, **(header or {})}
    rows = [_base_row(item) for item in items]
    last_written = [time.monotonic()]
    interrupted = False

    def write_summary() -> dict:
        document = summary_document(rows, {**header, "wall_time": time.perf_counter() - started})
        write_atomic(out / "summary.json", (json.dumps(document, indent=2) + "\n").encode())
        last_written[0] = time.monotonic()
        return document

    def finish(index: int, outcome: Outcome) -> None:
        with signals_deferred():
            record(index, outcome)
        if on_row is not None:
            on_row(rows[index])
        if time.monotonic() - last_written[0] >= SUMMARY_SECONDS:
            write_summary()

    def record(index: int, outcome: Outcome) -> None:
        """Write the spec's result file and fill its summary row."""
        item, row = items[index], rows[index]
        path = out / f"{item.stem}.json"
        row.update(status=outcome.status, message=outcome.message, time=outcome.time,
                   spec_sha256=outcome.spec_sha256,
                   errors=[{"pointer": p, "message": m} for p, m in outcome.errors])
        if outcome.status == RESUMED:
            from feedtune.schema.result import TuneResult

            try:
                result = TuneResult.model_validate_json(path.read_bytes())
                row.update(summary_fields(result), result=path.name, resumed=True)
            except (OSError, ValueError) as exc:  # replaced meanwhile: say so, don't guess
                row.update(status=ERROR, message=f"{path.name}: cannot reread: {exc}")
        elif outcome.result is not None:
            write_atomic(path, outcome.result)
            row.update(outcome.row, result=path.name)
        if baseline is not None:
            row["baseline"] = compare(row, baseline.get(item.stem), baseline_rtol)
        judge(row)

    with locked(out):
        remove_stale_temporaries(out)
        tasks = []
        for item in items:
            if item.data is None:
                finish(item.index, Outcome(INVALID, item.read_error or "cannot read",
                                           errors=[("", item.read_error or "cannot read")]))
            else:
                tasks.append((item.index, item.data, existing_sha256(out / f"{item.stem}.json")))
        executor_error = None
        try:
            executor.run(tasks, finish)
        except KeyboardInterrupt:
            interrupted = True
        except ExecutorError as exc:
            executor_error = str(exc)
        document = write_summary()
    return BatchOutcome(document, time.perf_counter() - started, interrupted, executor_error)
