"""What every command shares: exit statuses, reading a spec, writing output, errors.

Errors go to stderr as ``error: ...`` lines and end the command with :data:`EXIT_BAD_INPUT`
(or the status given); output goes to stdout or atomically to a file.
"""

from __future__ import annotations

import contextlib
import os
import sys
import typing
from pathlib import Path
from typing import Iterator

import click

from feedtune.schema.files import write_atomic


#: exit statuses, also listed in ``feedtune --help``
EXIT_OK, EXIT_NOT_SUCCESS, EXIT_BAD_INPUT, EXIT_INTERNAL = 0, 1, 2, 3

STDIN = "-"

EPILOG = ("Exit status: 0 success; 1 the tuning did not succeed (the result is still "
          "written); 2 the spec or a file cannot be used; 3 internal error (please report).")


def err(message: str = "") -> None:
    click.echo(message, err=True)


def fail(message: str, code: int = EXIT_BAD_INPUT) -> typing.NoReturn:
    err(f"error: {message}")
    raise SystemExit(code)


def internal_error(exc: BaseException, send: str) -> typing.NoReturn:
    """A bug: its traceback on stderr, then exit 3 naming feedtune's version and ``exc``;
    ``send``: what to report it with ("the spec", "the data")."""
    import traceback

    from feedtune import __version__

    traceback.print_exc()
    fail(f"internal error in feedtune {__version__} ({type(exc).__name__}: {exc}); "
         f"please report it with {send}", EXIT_INTERNAL)


#: ``-q/--quiet`` of the commands that print a summary to stderr
QUIET = click.option("-q", "--quiet", is_flag=True, help="Do not print the summary to stderr.")


def spec_errors(label: str, errors: list[tuple[str, str]]) -> typing.NoReturn:
    """One ``error: LABEL: POINTER: message`` line per problem, then exit 2."""
    from feedtune.schema.spec import printable

    for pointer, message in errors:
        where = f"{label}: {printable(pointer)}" if pointer else label
        err(f"error: {where}: {printable(message)}")
    raise SystemExit(EXIT_BAD_INPUT)


def spec_label(spec: str) -> str:
    return "<stdin>" if spec == STDIN else spec


def read_spec(spec: str) -> bytes:
    """The bytes of SPEC (a path or ``-``), or exit 2 with the reason it cannot be read."""
    from feedtune.schema.spec import MAX_SPEC_BYTES

    try:
        if spec == STDIN:
            data = click.get_binary_stream("stdin").read(MAX_SPEC_BYTES + 1)
        else:
            with open(spec, "rb") as handle:
                data = handle.read(MAX_SPEC_BYTES + 1)
    except FileNotFoundError:
        fail(f"{spec_label(spec)}: no such file")
    except IsADirectoryError:
        fail(f"{spec_label(spec)}: is a directory, not a spec file")
    except PermissionError:
        fail(f"{spec_label(spec)}: permission denied")
    except OSError as exc:
        fail(f"{spec_label(spec)}: cannot read: {exc.strerror or exc}")
    if len(data) > MAX_SPEC_BYTES:
        fail(f"{spec_label(spec)}: spec is larger than the limit of {MAX_SPEC_BYTES} bytes")
    return data


def parse(spec: str):
    """Read and parse SPEC, or print its errors and exit 2."""
    from feedtune.schema.spec import SpecError, parse_spec

    data = read_spec(spec)
    try:
        return parse_spec(data)
    except SpecError as exc:
        spec_errors(spec_label(spec), exc.errors)


def check_output(output: str | None) -> Path | None:
    """The output path (None for stdout); exit 2 now if it cannot be written later."""
    if output is None or output == STDIN:
        return None
    path = Path(output)
    if path.is_dir():
        fail(f"{output}: is a directory; give a file name for the output")
    if not path.parent.is_dir():
        fail(f"{output}: directory {str(path.parent)!r} does not exist")
    return path


def emit(data: bytes, path: Path | None) -> None:
    """``data`` to stdout (path None) or atomically to ``path``; exit 2 if that fails."""
    if path is None:
        stream = click.get_binary_stream("stdout")
        stream.write(data)
        stream.flush()
        return
    try:
        write_atomic(path, data)
    except OSError as exc:
        fail(f"{path}: cannot write: {exc.strerror or exc}")


def _flush_c_stdio() -> None:
    """Flush the C library's stdio buffers (IPOPT writes through them)."""
    import ctypes  # not at the top: `validate` and `--help` need no C library

    with contextlib.suppress(Exception):
        ctypes.CDLL(None).fflush(None)


@contextlib.contextmanager
def stdout_to_stderr() -> Iterator[None]:
    """Send everything written to file descriptor 1 (C or Python) to stderr meanwhile."""
    sys.stdout.flush()
    _flush_c_stdio()
    try:
        saved = os.dup(1)
    except OSError:  # no file descriptor 1: nothing to protect
        saved = None
    if saved is not None:
        try:
            os.dup2(2, 1)
        except OSError:  # no file descriptor 2: send the solver's chatter nowhere
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, 1)
            os.close(devnull)
    try:
        with contextlib.redirect_stdout(sys.stderr):
            yield
    finally:
        sys.stderr.flush()
        _flush_c_stdio()
        if saved is not None:
            os.dup2(saved, 1)
            os.close(saved)


@contextlib.contextmanager
def computing() -> Iterator[None]:
    """Solver chatter to stderr; Ctrl-C ends the command with status 130, nothing written."""
    try:
        with stdout_to_stderr():
            yield
    except KeyboardInterrupt:
        fail("interrupted; nothing written", 130)


def fmt(value: float | None) -> str:
    """A number for people: six significant digits, or ``n/a``."""
    return "n/a" if value is None else f"{value:.6g}"


#: the type of an option that must be a positive number
POSITIVE = click.FloatRange(min=0, min_open=True)
