"""The ``feedtune`` command line: the group and its commands, one module each.

``feedtune tune SPEC`` writes the result JSON, and only that, to stdout (or ``-o``);
everything meant for people (the summary, errors, anything IPOPT or CasADi print)
goes to stderr. Exit status: 0 a successful tuning, 1 a result with ``success`` false
(still written), 2 a spec or file that cannot be used, 3 an internal error, 130
interrupted.

Each command's module is imported when the command is looked up (``feedtune validate``
loads only its own; ``--help`` lists them all), and imports only click and the standard
library at load time; what a command needs beyond that (pydantic, numpy, CasADi, the
tuner) it imports when it runs, so ``feedtune --help`` and ``feedtune validate`` start
quickly (tests/cli/test_startup_imports.py).
"""

from __future__ import annotations

import contextlib
import sys

import click

from feedtune import __version__, collector, interrupts
from feedtune.cli.common import EPILOG
from feedtune.lazy import Loaded

#: command name → its function, as "module:function" (the module imported when the command
#: is looked up)
COMMAND_PATHS = {
    "batch": "feedtune.cli.batch:batch",
    "chart": "feedtune.cli.chart:chart",
    "examples": "feedtune.cli.examples:examples",
    "identify": "feedtune.cli.identify:identify",
    "metrics": "feedtune.cli.metrics:metrics",
    "plants": "feedtune.cli.plants:plants",
    "report": "feedtune.cli.report:report",
    "schema": "feedtune.cli.schema:schema",
    "select": "feedtune.cli.select:select_command",
    "simulate": "feedtune.cli.simulate:simulate",
    "tune": "feedtune.cli.tune:tune",
    "validate": "feedtune.cli.validate:validate",
}


@click.group(context_settings={"help_option_names": ["-h", "--help"]}, epilog=EPILOG,
             commands=Loaded(COMMAND_PATHS))
@click.version_option(__version__, "-V", "--version", prog_name="feedtune")
def main() -> None:
    """Tune CNC feed drives (gains [1/s], sampling periods [s], compensators) by
    optimisation with CasADi and IPOPT.

    A JSON spec names the plant, which tunables are free, what to minimise and what
    must hold; all values are SI. Start with `feedtune examples`, `feedtune plants`
    and `feedtune metrics`.
    """
    with contextlib.suppress(AttributeError, ValueError):
        sys.stderr.reconfigure(errors="backslashreplace")
    collector.release()
    if click.get_current_context().invoked_subcommand != "batch":  # batch: its _Stop does
        interrupts.release()

