"""``feedtune examples``: list, print or copy the bundled example specs."""

from __future__ import annotations

import json
import re
from pathlib import Path

import click

from feedtune.cli.common import check_output, emit, err, fail


def examples_dir() -> Path:
    """Bundled example specs: ``feedtune/examples`` in a wheel, ``examples/`` in the repo."""
    import feedtune

    package = Path(feedtune.__file__).resolve().parent
    bundled = package / "examples"
    return bundled if bundled.is_dir() else package.parent / "examples"


def bundled_examples() -> dict[str, Path]:
    """Name (the file's stem) → path of every bundled example spec."""
    directory = examples_dir()
    if not directory.is_dir():
        return {}
    return {p.stem: p for p in sorted(directory.glob("*.json")) if p.is_file()}


#: a sentence ends at ". " after a word of two lower-case letters or digits ("… drive. The"),
#: not after an abbreviation such as "Ch. IV" or "Fig. 3"
_SENTENCE_END = re.compile(r"(?<=[a-z0-9)][a-z0-9)])\.\s+(?=[A-Z])")


def _shorten(text: str, width: int = 90) -> str:
    text = " ".join(text.split())
    sentence = _SENTENCE_END.split(text)[0].rstrip(".")
    if len(sentence) <= width:
        return sentence
    return sentence[: width - 1].rstrip() + "…"


def _example_description(path: Path) -> str:
    try:
        data = json.loads(path.read_bytes())
        return str(data.get("description", "")) if isinstance(data, dict) else ""
    except (OSError, ValueError):
        return "(unreadable)"


@click.command()
@click.argument("name", required=False)
@click.option("-o", "--output", metavar="PATH",
              help="Copy the example spec here instead of printing it; '-' is stdout.")
def examples(name: str | None, output: str | None) -> None:
    """List the bundled example specs, or print (or copy) the one called NAME."""
    known = bundled_examples()
    if name is None:
        if not known:
            err(f"no examples found in {examples_dir()}")
            return
        width = max(len(stem) for stem in known)
        room = max(40, 100 - width - 2)  # lines of at most 100 characters
        for stem, path in known.items():
            click.echo(f"{stem:<{width}}  {_shorten(_example_description(path), room)}")
        return
    stem = name[:-5] if name.endswith(".json") else name
    if stem not in known:
        listing = ", ".join(known) or f"none (looked in {examples_dir()})"
        fail(f"unknown example {name!r}; known: {listing}")
    target = check_output(output)
    try:
        data = known[stem].read_bytes()
    except OSError as exc:
        fail(f"{known[stem]}: cannot read: {exc.strerror or exc}")
    emit(data, target)
    if target is not None:
        err(f"wrote {target}")
