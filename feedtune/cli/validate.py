"""``feedtune validate``: check a spec without solving it."""

from __future__ import annotations

import click

from feedtune import collector
from feedtune.cli.common import EPILOG, err, parse


@click.command(epilog=EPILOG)
@click.argument("spec", metavar="SPEC")
def validate(spec: str) -> None:
    """Check SPEC (a JSON file, or '-' for stdin) without solving it.

    Checks the JSON, every field and unit range, tunable names, that each metric applies
    to the plant, that each tunable's bounds [its unit] are not empty, the IPOPT options'
    allow-list and the work limits (terms, constraints, step-response samples): exactly
    what `tune` refuses. Prints `ok: NAME` to stderr, or one
    `error: SPEC: /json/pointer: message` line per problem.
    """
    with collector.paused():  # one spec's models, kept until the process ends
        parsed = parse(spec)
    err(f"ok: {parsed.name}")  # a name holds printable characters only
