"""Ctrl-C and SIGTERM while the command line starts: exit 130 at once, nothing done.

Loading the command line takes 0.2–0.5 s (click, pydantic). :func:`hold` installs
:func:`stop_while_starting` for SIGINT and SIGTERM before that; :func:`release` puts the
process's own handlers back once a command is about to run. ``feedtune batch`` skips the
release and replaces the handlers itself in its first line (its ``_Stop``), so no moment is
left where a signal gives click's "Aborted!" (exit 1) or the default SIGTERM (exit 143).
Light on purpose: imported before anything else of the command line.
"""

import os
import signal

SIGNALS = (signal.SIGINT, signal.SIGTERM)
_held: dict = {}


def stop_while_starting(signum, frame):
    """Exit 130 now: an exception raised here could be swallowed inside an import."""
    os.write(2, b"feedtune: interrupted while starting; nothing was done\n")
    os._exit(130)


def hold() -> None:
    """Exit 130 on SIGINT/SIGTERM from now until :func:`release` (the handlers before are
    remembered once)."""
    for signum in SIGNALS:
        previous = signal.signal(signum, stop_while_starting)
        _held.setdefault(signum, previous)


def release() -> None:
    """The handlers from before :func:`hold`; nothing if none are held (idempotent)."""
    while _held:
        signum, handler = _held.popitem()
        signal.signal(signum, handler)
