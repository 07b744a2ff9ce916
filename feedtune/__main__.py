"""``python -m feedtune`` and the ``feedtune`` script: the command line of :mod:`feedtune.cli`.

Loading the command line takes 0.2–0.5 s (click, pydantic). A Ctrl-C or SIGTERM meanwhile
ends the process at once with exit status 130 and one line (nothing has been written yet),
not a traceback or status 143; once loaded, each command handles signals itself
(``batch``: 130, the results so far kept).
"""

import os
import signal

_STARTING = (signal.SIGINT, signal.SIGTERM)


def _stop_while_starting(signum, frame):
    """Exit 130 now: an exception raised here could be swallowed inside an import."""
    os.write(2, b"feedtune: interrupted while starting; nothing was done\n")
    os._exit(130)


def main() -> None:
    """Load the command line and run it; an interrupt while it loads is exit status 130."""
    previous = {signum: signal.signal(signum, _stop_while_starting) for signum in _STARTING}
    from feedtune.cli import main as command_line

    for signum, handler in previous.items():
        signal.signal(signum, handler)
    command_line(prog_name="feedtune")


if __name__ == "__main__":
    main()
