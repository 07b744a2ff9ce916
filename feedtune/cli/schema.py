"""``feedtune schema``: the JSON Schema of a spec."""

from __future__ import annotations

import json

import click

from feedtune.cli.common import emit


@click.command()
def schema() -> None:
    """Print the JSON Schema of a spec (units are in the field descriptions)."""
    from feedtune.schema.spec import spec_json_schema

    text = json.dumps(spec_json_schema(), indent=2, ensure_ascii=False) + "\n"
    emit(text.encode("utf-8"), None)
