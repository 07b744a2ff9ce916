"""Turning the batch's INPUT arguments into a list of specs, each with its result file name.

An INPUT is a spec file (``*.json``), a JSON Lines file (``*.jsonl``, one spec per line),
a directory (every ``*.json`` and ``*.jsonl`` below it, sorted) or a glob pattern
(``**`` allowed). A spec that cannot be read or parsed is still an item: it becomes a row
of the batch's summary with the reason. Only inputs that name nothing usable (a missing
path, a pattern that matches nothing) raise :class:`InputError`.
"""

from __future__ import annotations

import fnmatch
import glob
import json
import re
from dataclasses import dataclass
from pathlib import Path

from feedtune.schema.spec import MAX_SPEC_BYTES

SPEC_SUFFIXES = (".json", ".jsonl")
#: result files are named after the spec: these characters are kept, runs of others → "_"
_UNSAFE = re.compile(r"[^A-Za-z0-9._-]+")
MAX_STEM = 100
#: result stems the batch keeps for its own files
RESERVED_STEMS = {"summary"}


class InputError(ValueError):
    """The batch's inputs themselves cannot be used (exit status 2)."""


@dataclass
class Item:
    """One spec of the batch.

    ``label`` names it for people (``path`` or ``path:line``); ``data`` holds its bytes,
    or ``None`` with ``read_error`` saying why they could not be read; ``stem`` is the
    name of its result file in the output directory, without ``.json``.
    """

    index: int
    label: str
    path: str
    line: int | None
    data: bytes | None
    read_error: str | None
    name: str
    stem: str = ""


def _is_pattern(text: str) -> bool:
    return any(ch in text for ch in "*?[")


def expand(inputs: list[str]) -> list[Path]:
    """Spec files named by ``inputs``, in the order given, each once.

    Raises
    ------
    InputError
        For an input that does not exist, a pattern or directory with no spec files in it,
        or a file that is neither ``.json`` nor ``.jsonl``.
    """
    files: list[Path] = []
    seen: set[Path] = set()

    def add(path: Path) -> None:
        key = path.resolve()
        if key not in seen:
            seen.add(key)
            files.append(path)

    for text in inputs:
        path = Path(text)
        if path.is_dir():
            found = sorted(p for p in path.rglob("*")
                           if p.suffix in SPEC_SUFFIXES and p.is_file()
                           and not any(part.startswith(".") for part in p.relative_to(path).parts))
            if not found:
                raise InputError(f"{text}: directory holds no *.json or *.jsonl spec files")
            for p in found:
                add(p)
        elif path.is_file():
            if path.suffix not in SPEC_SUFFIXES:
                raise InputError(f"{text}: not a spec file (expected *.json or *.jsonl)")
            add(path)
        elif _is_pattern(text):
            found = sorted(Path(p) for p in glob.glob(text, recursive=True)
                           if Path(p).is_file() and Path(p).suffix in SPEC_SUFFIXES)
            if not found:
                raise InputError(f"{text}: pattern matches no *.json or *.jsonl files")
            for p in found:
                add(p)
        elif path.exists():
            raise InputError(f"{text}: neither a file nor a directory")
        else:
            raise InputError(f"{text}: no such file or directory")
    return files


def _pattern_base(pattern: str) -> Path:
    """The directory a glob pattern searches: its path up to the first wildcard part."""
    base = []
    for part in Path(pattern).parts:
        if _is_pattern(part):
            break
        base.append(part)
    return Path(*base) if base else Path(".")


def _pattern_reaches(pattern: str, target: Path) -> bool:
    """Whether files directly in ``target`` could match ``pattern``: it lies below the
    pattern's base and, unless the pattern is recursive (``**``), at the depth the pattern
    matches files, through directories its parts match."""
    base = _pattern_base(pattern)
    parts = Path(pattern).parts[len(base.parts):]
    try:
        inside = target.relative_to(base.resolve()).parts
    except ValueError:
        return False
    if any("**" in part for part in parts):
        return True
    return (len(parts) == len(inside) + 1
            and all(fnmatch.fnmatchcase(name, part) for name, part in zip(inside, parts)))


def check_output_apart(inputs: list[str], out: Path) -> None:
    """Refuse an output directory where the inputs are read from.

    Results must not replace a spec nor be read as specs by a rerun: ``out`` may be neither
    a directory input nor inside one (searched recursively), nor hold files a pattern input
    matches, nor be a spec file's own directory. Paths are compared resolved, so a symbolic
    link to an input is refused too; ``out`` need not exist yet.

    Raises
    ------
    InputError
        Naming ``out`` and the input it collides with.
    """
    target = out.resolve()
    for text in inputs:
        path = Path(text)
        if path.is_file():
            clash = "is the directory of the input" if target == path.resolve().parent else None
        elif path.is_dir():
            root = path.resolve()
            clash = ("is the input" if target == root else
                     "lies inside the input" if root in target.parents else None)
        elif _is_pattern(text):
            clash = "holds files matched by the input" if _pattern_reaches(text, target) else None
        else:
            clash = None  # names nothing: expand() says so
        if clash:
            raise InputError(f"--out {out} {clash} {text}: results would replace specs or be "
                             "read as specs by a rerun; choose a directory apart from the inputs")


def _spec_name(data: bytes | None, fallback: str) -> str:
    """The spec's ``name`` if it has a usable one, else ``fallback``."""
    if data is None:
        return fallback
    try:
        value = json.loads(data)
    except (ValueError, RecursionError):
        return fallback
    name = value.get("name") if isinstance(value, dict) else None
    return name if isinstance(name, str) and name.strip() else fallback


def _read_file(path: Path) -> tuple[bytes | None, str | None]:
    try:
        with open(path, "rb") as handle:
            data = handle.read(MAX_SPEC_BYTES + 1)
    except OSError as exc:
        return None, f"cannot read: {exc.strerror or exc}"
    if len(data) > MAX_SPEC_BYTES:
        return None, f"spec is larger than the limit of {MAX_SPEC_BYTES} bytes"
    return data, None


def _read_lines(path: Path):
    """(line number, bytes or None, error) for each non-blank line of a JSON Lines file."""
    try:
        handle = open(path, "rb")
    except OSError as exc:
        yield None, None, f"cannot read: {exc.strerror or exc}"
        return
    with handle:
        for number, line in enumerate(handle, start=1):
            if not line.strip():
                continue
            if len(line) > MAX_SPEC_BYTES:
                yield number, None, f"spec is larger than the limit of {MAX_SPEC_BYTES} bytes"
            else:
                yield number, line, None


def load_items(inputs: list[str]) -> list[Item]:
    """Every spec named by ``inputs``, read, named, with a unique result stem each."""
    items: list[Item] = []
    for path in expand(inputs):
        if path.suffix == ".jsonl":
            for line, data, error in _read_lines(path):
                label = f"{path}:{line}" if line is not None else str(path)
                fallback = f"{path.stem}-{line}" if line is not None else path.stem
                items.append(Item(len(items), label, str(path), line, data, error,
                                  _spec_name(data, fallback)))
        else:
            data, error = _read_file(path)
            items.append(Item(len(items), str(path), str(path), None, data, error,
                              _spec_name(data, path.stem)))
    assign_stems(items)
    return items


def safe_stem(name: str) -> str:
    """A file-name stem for a spec name: safe characters only, at most MAX_STEM long."""
    stem = _UNSAFE.sub("_", name).strip("._")[:MAX_STEM].strip("._")
    return stem or "spec"


def assign_stems(items: list[Item]) -> None:
    """Give each item a result stem from its name; later collisions get ``-2``, ``-3``, …

    Collisions are judged without case (two names differing only in case would share a
    file on macOS and Windows) and in input order, so a rerun of the same inputs names
    every result the same.
    """
    taken = set(RESERVED_STEMS)
    for item in items:
        base = safe_stem(item.name)
        stem, n = base, 1
        while stem.lower() in taken:
            n += 1
            stem = f"{base}-{n}"
        taken.add(stem.lower())
        item.stem = stem
