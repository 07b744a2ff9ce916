"""``feedtune batch``: many specs in parallel processes or on Dask, with its own handling of
Ctrl-C and SIGTERM (exit 130, the results so far kept)."""

from __future__ import annotations

import signal
import typing
from pathlib import Path

import click

from feedtune.cli.common import (EXIT_NOT_SUCCESS, EXIT_OK, check_output, emit, err, fail,
                                 stdout_to_stderr)


_BATCH_EPILOG = ("Exit status: 0 every spec solved and met its constraints (and, with "
                 "--baseline, is not worse); 1 some spec did not; 2 the inputs, the output "
                 "directory, the baseline or the Dask cluster cannot be used; 130 "
                 "interrupted by Ctrl-C or SIGTERM (results so far are kept; rerun to "
                 "finish).")


@click.command(epilog=_BATCH_EPILOG)
@click.argument("inputs", nargs=-1, required=True, metavar="INPUT...")
@click.option("--out", "out", required=True, metavar="DIR",
              help="Directory for one result file per spec (NAME.json) and summary.json; "
                   "created if missing. Results already there for the same spec and feedtune "
                   "version are kept, not solved again.")
@click.option("--executor", type=click.Choice(["local", "dask"]), default=None,
              help="local (default): worker processes on this machine; dask: a dask.distributed "
                   "cluster, a local one unless --scheduler names one.")
@click.option("--scheduler", metavar="ADDRESS",
              help="Address of a running Dask scheduler, e.g. tcp://10.0.0.5:8786 "
                   "(implies --executor dask).")
@click.option("-j", "--workers", type=click.IntRange(min=1), default=None,
              help="Worker processes [count]; default: every core of this machine.")
@click.option("--timeout", type=click.FloatRange(min=0, min_open=True), default=None,
              metavar="SECONDS",
              help="Stop a spec that runs longer than this [s] (status timeout); local "
                   "executor only. Each IPOPT solve also has the spec's own solver.time_limit.")
@click.option("--junit", "junit", metavar="FILE",
              help="Also write JUnit XML: one test case per spec (its file and line), a "
                   "failure when it is invalid, unsolved, violates a constraint, fails the "
                   "independent validation or is worse than the baseline, with that reason "
                   "as its type.")
@click.option("--format", "output_format", type=click.Choice(["text", "github"]),
              default="text", show_default=True,
              help="github: also print GitHub Actions ::error annotations on stdout, one per "
                   "failing spec, naming its file.")
@click.option("--baseline", metavar="DIR",
              help="--out directory of an earlier batch: a spec whose objective is now worse "
                   "than there (beyond --baseline-rtol) fails.")
@click.option("--baseline-rtol", type=click.FloatRange(min=0), default=1e-6,
              show_default=True, metavar="RTOL",
              help="Relative tolerance of the baseline comparison [1].")
@click.option("--worker-timeout", type=click.FloatRange(min=0, min_open=True), default=60.0,
              show_default=True, metavar="SECONDS",
              help="Dask only: stop with exit status 2 when no worker has joined the scheduler "
                   "within this time [s]; also the time allowed to connect to it.")
@click.option("-q", "--quiet", is_flag=True,
              help="No progress and no table on stderr (the totals line is still printed).")
def batch(inputs: tuple[str, ...], out: str, executor: str | None, scheduler: str | None,
          workers: int | None, timeout: float | None, worker_timeout: float,
          junit: str | None, output_format: str, baseline: str | None, baseline_rtol: float,
          quiet: bool) -> None:
    """Tune many specs in parallel: one result per spec in DIR, plus DIR/summary.json.

    INPUT is a spec file (*.json), a JSON Lines file (*.jsonl, one spec per line), a
    directory (every *.json and *.jsonl below it) or a quoted glob pattern ('specs/**/*.json').
    A spec that is invalid, fails to solve, times out or kills its worker becomes a row with
    its status and message; the others still run.
    """
    stop = _Stop()  # first, before the slow imports: Ctrl-C or SIGTERM is exit 130 from here
    try:
        _batch(inputs, out, executor, scheduler, workers, timeout, worker_timeout, junit,
               output_format, baseline, baseline_rtol, quiet, stop)
    except KeyboardInterrupt:
        _interrupted()
    finally:
        stop.restore()


class _Stop:
    """Ctrl-C and SIGTERM (how CI cancels) during a batch, both a KeyboardInterrupt.

    While the batch loads (slow imports) a signal is only remembered: an exception raised
    inside an import can be swallowed ("Exception ignored in ...") or, inside an extension
    module's own Python code, make the interpreter exit by SIGINT whatever we then do.
    :meth:`arm` raises a remembered one, then lets later signals raise at once; :meth:`check`
    raises one that was swallowed anyway.
    """

    def __init__(self) -> None:
        self.requested = False
        self.previous = {signum: signal.signal(signum, self._remember)
                         for signum in (signal.SIGINT, signal.SIGTERM)}

    def _remember(self, signum, frame) -> None:
        self.requested = True

    def _raise(self, signum, frame) -> typing.NoReturn:
        self.requested = True
        raise KeyboardInterrupt

    def arm(self) -> None:
        self.check()
        for signum in (signal.SIGINT, signal.SIGTERM):
            signal.signal(signum, self._raise)

    def check(self) -> None:
        if self.requested:
            raise KeyboardInterrupt

    def restore(self) -> None:
        """The handlers from before, for a caller that goes on (tests calling in process)."""
        for signum, handler in self.previous.items():
            signal.signal(signum, handler)


def _interrupted() -> typing.NoReturn:
    for signum in (signal.SIGINT, signal.SIGTERM):  # a second signal must not cut this short
        signal.signal(signum, signal.SIG_IGN)
    err("interrupted: the results written so far are kept; rerun the same command to finish")
    raise SystemExit(130)


def _batch(inputs: tuple[str, ...], out: str, executor: str | None, scheduler: str | None,
           workers: int | None, timeout: float | None, worker_timeout: float,
           junit: str | None, output_format: str, baseline: str | None, baseline_rtol: float,
           quiet: bool, stop: _Stop) -> None:
    """The batch command once its signal handling (``stop``) is in place."""
    if scheduler is not None and executor == "local":
        fail("--scheduler needs the dask executor; drop --executor local")
    kind = "dask" if scheduler is not None else (executor or "local")
    if kind == "dask" and timeout is not None:
        fail("--timeout is enforced by the local executor only; with Dask, each spec's "
             "solver.time_limit bounds its IPOPT solves")
    if kind == "dask":
        try:
            import distributed  # noqa: F401
        except ImportError:
            fail("--executor dask and --scheduler need Dask, which is not installed: "
                 "pip install 'feedtune[dask]'")
    junit_path = check_output(junit) if junit is not None else None

    from feedtune.batch.dask_cluster import DaskExecutor
    from feedtune.batch.inputs import InputError
    from feedtune.batch.local import LocalExecutor
    from feedtune.batch.progress import Progress
    from feedtune.batch.reports import (BaselineError, github_annotations, junit_xml,
                                        load_baseline, table, totals_line)
    from feedtune.batch.runner import run_batch

    baseline_rows = None
    if baseline is not None:
        try:
            baseline_rows = load_baseline(Path(baseline))
        except BaselineError as exc:
            fail(str(exc))
    if kind == "dask":
        runner = DaskExecutor(scheduler, workers, worker_timeout=worker_timeout)
        header = {"executor": "dask", "scheduler": scheduler or "local cluster",
                  "workers": workers}
    else:
        runner = LocalExecutor(workers, timeout)
        header = {"executor": "local", "workers": runner.workers}
    progress = [None]

    def on_row(row: dict) -> None:
        stop.check()
        if progress[0] is not None:
            progress[0].update(row["ok"])

    class _Counted:  # starts the progress display once the number of specs is known
        def __init__(self, inner):
            self.inner = inner

        def run(self, tasks, on_outcome):
            progress[0] = Progress(len(tasks), enabled=not quiet)
            try:
                self.inner.run(tasks, on_outcome)
            finally:
                progress[0].close()

    stop.arm()
    try:
        with stdout_to_stderr():
            outcome = run_batch(list(inputs), Path(out), _Counted(runner),
                                baseline=baseline_rows, baseline_rtol=baseline_rtol,
                                on_row=on_row, header=header)
    except InputError as exc:
        fail(str(exc))
    except OSError as exc:
        fail(f"{out}: {exc.strerror or exc}")
    if outcome.executor_error is not None:
        fail(f"{outcome.executor_error} (summary: {Path(out) / 'summary.json'})")
    rows = outcome.document["rows"]
    if not quiet:
        for line in table(rows):
            err(line)
    err(totals_line(outcome.document, outcome.wall))
    if junit_path is not None:
        emit(junit_xml(rows, outcome.wall), junit_path)
    if output_format == "github":
        for line in github_annotations(rows):
            click.echo(line)
    if outcome.interrupted or stop.requested:
        _interrupted()
    raise SystemExit(EXIT_OK if outcome.document["failed"] == 0 else EXIT_NOT_SUCCESS)
