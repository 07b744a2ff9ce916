"""``python -m feedtune`` and the ``feedtune`` script: the command line of :mod:`feedtune.cli`.

Loading the command line takes 0.2–0.5 s (click, pydantic). A Ctrl-C or SIGTERM meanwhile
ends the process at once with exit status 130 and one line (nothing has been written yet),
not a traceback or status 143 (:mod:`feedtune.interrupts`); once a command runs, it handles
signals itself (``batch``: 130, the results so far kept).
"""

import atexit
import os
import sys
import threading

from feedtune import collector, interrupts

#: thread-count variables of the BLAS libraries numpy and scipy may load
BLAS_THREADS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def pin_blas_threads(environ=os.environ) -> None:
    """One BLAS thread unless the user chose otherwise; effective only before numpy loads.

    The tuner and the validator run many small matrix operations (expm, eigvals, solves of
    2×2–10×10 matrices), for which a second BLAS thread only adds synchronisation, and
    ``feedtune batch`` runs one worker process per core, which inherit this environment:
    300 generated specs on 2 cores went from 12.5 to 21.1 specs/s with 2 workers
    (benchmarks/batch_throughput.py), and a single tuning keeps its wall time at half the
    CPU time.
    """
    for name in BLAS_THREADS:
        environ.setdefault(name, "1")


def skip_pydantic_plugins(environ=os.environ) -> None:
    """No pydantic plugins (pydantic's ``PYDANTIC_DISABLE_PLUGINS``) unless the user chose.

    pydantic looks for plugins when it builds its first validator by reading the
    entry points of every installed distribution, ≈ 2 % of ``feedtune validate``'s start-up
    (issue 15; benchmarks/README.md), and a plugin would run on every spec this command
    checks. A Python caller of :mod:`feedtune` keeps its own setting.
    """
    environ.setdefault("PYDANTIC_DISABLE_PLUGINS", "__all__")


def main() -> None:
    """The ``feedtune`` command: :func:`run`, then exit without the interpreter's teardown."""
    exit_without_teardown(run())


def run(args: list[str] | None = None):
    """Load the command line and run it on ``args`` (None: ``sys.argv[1:]``); its exit code
    (as ``SystemExit.code``: None, a number or a message). An interrupt while it loads is
    exit status 130; the cyclic garbage collector is off while it loads
    (:mod:`feedtune.collector`) and as it was before once ``run`` returns."""
    interrupts.hold()  # released by the command about to run (feedtune.cli.main)
    collector.hold()  # likewise
    pin_blas_threads()
    skip_pydantic_plugins()
    from feedtune.cli import main as command_line

    try:
        command_line(args=args, prog_name="feedtune")
    except SystemExit as stop:
        return stop.code
    finally:
        interrupts.release()  # if no command ran (--help, a usage error)
        collector.release()
    return 0


def exit_without_teardown(code) -> None:
    """End the process with ``code`` (as ``sys.exit`` would) without the interpreter's
    teardown, once the command is over.

    Freeing every module and CasADi graph at exit took 0.45 s after a Koren tuning
    (measured side by side with ``os._exit``: 2.68 → 2.22 s wall), longer than most
    tunings' solve. Everything the process still owes is done first: atexit handlers run,
    stdout and stderr are flushed. A process with other non-daemon threads still running
    exits the normal way (``sys.exit``), which waits for them.
    """
    if code is None:
        code = 0
    elif not isinstance(code, int):
        print(code, file=sys.stderr)
        code = 1
    if any(t is not threading.main_thread() and not t.daemon for t in threading.enumerate()):
        sys.exit(code)
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe (`feedtune ... | head`)
            code = code or 1
    os._exit(code)


if __name__ == "__main__":
    main()
