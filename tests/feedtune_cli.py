"""``feedtune ARGS`` inside the test process, through the command's real entry point.

:func:`run_cli` calls :func:`feedtune.__main__.run` (what the ``feedtune`` script and
``python -m feedtune`` run before they exit) with the process set up as a fresh
``feedtune`` process would find it, and returns what ``subprocess.run([sys.executable,
"-m", "feedtune", *args], capture_output=True)`` returns: a
:class:`subprocess.CompletedProcess` with the exit status, stdout and stderr.

What a test sees is what a user's terminal gets, not only what Python wrote:

- file descriptors 1 and 2 are files of their own meanwhile, and ``sys.stdout`` and
  ``sys.stderr`` write to them (UTF-8; stderr with ``backslashreplace``, as the command
  sets it), so IPOPT's or C's ``printf`` lands where it would, in the order it would, and
  a test that stdout holds only JSON fails if a solver prints on it;
- ``sys.stdin`` reads ``stdin`` (bytes; empty by default, like ``input=b""``);
- warnings are filtered and shown as by an interpreter started without ``-W`` (pytest's own
  filters and recording are set aside), so "no warning on stderr" is tested, not hidden;
- an exception that escapes the command prints its traceback on stderr and gives status 1,
  as the interpreter would; ``SystemExit`` codes map as ``sys.exit`` maps them;
- the working directory (``cwd``), environment variables (``env``: added or changed, as
  ``{**os.environ, **env}``) and the SIGINT/SIGTERM handlers are put back afterwards.

Saved per call: the ≈ 1 s of CPU a ``python -m feedtune`` process spends importing click,
pydantic, numpy, scipy and CasADi (≈ 45 % of the suite's CPU went to such starts;
benchmarks/README.md, "The test suite's CPU"). A solver the tuner built for an earlier
test is reused here as in a batch; results do not depend on it (tests/unit/test_solver_reuse.py).

What still needs a fresh interpreter, so keep ``subprocess`` there: the process's exit
(``feedtune.__main__.main`` ends without the interpreter's teardown), a signal while the
command line loads, what a fresh interpreter imports (tests/cli/test_startup_imports.py),
anything printed once per process (IPOPT's banner) and the console script itself. A signal
sent to a running command, or a ``feedtune batch`` whose Dask scheduler is lost, needs a
process but not a fresh interpreter: :func:`start_cli` forks one from this process
(tests/README.md).
"""

from __future__ import annotations

import contextlib
import ctypes
import io
import logging
import multiprocessing
import os
import signal
import subprocess
import sys
import tempfile
import traceback
import warnings
from pathlib import Path

import feedtune.__main__
from feedtune.__main__ import run

REPO = Path(__file__).resolve().parents[1]

#: the warning filters of ``python`` started without -W or PYTHONWARNINGS (the docs of the
#: warnings module, "Default Warning Filter"), first match first
DEFAULT_WARNING_FILTERS = (
    ("default", DeprecationWarning, "__main__"),
    ("ignore", DeprecationWarning, ""),
    ("ignore", PendingDeprecationWarning, ""),
    ("ignore", ImportWarning, ""),
    ("ignore", ResourceWarning, ""),
)

_libc = ctypes.CDLL(None)


def _flush_c_stdio() -> None:
    _libc.fflush(None)


def _exit_status(code) -> tuple[int, str]:
    """(status, text for stderr) of ``sys.exit(code)``."""
    if code is None:
        return 0, ""
    if isinstance(code, int):
        return code & 0xFF, ""
    return 1, f"{code}\n"


def _default_warnings() -> None:
    """The warning filters and display of ``python`` started without -W."""
    warnings.resetwarnings()
    for action, category, module in DEFAULT_WARNING_FILTERS:
        warnings.filterwarnings(action, category=category, module=module, append=True)
    warnings.showwarning = _show_on_stderr  # not pytest's record (catch_warnings(record=True))


def _interpreter_streams(stdin_fd: int) -> None:
    """``sys.stdin``, ``sys.stdout`` and ``sys.stderr`` as a fresh interpreter opens them,
    on file descriptors ``stdin_fd``, 1 and 2 (UTF-8; stderr backslash-escaped and
    line-buffered)."""
    sys.stdin = io.TextIOWrapper(io.BufferedReader(io.FileIO(stdin_fd, "r", closefd=False)),
                                 encoding="utf-8")
    sys.stdout = io.TextIOWrapper(io.BufferedWriter(io.FileIO(1, "w", closefd=False)),
                                  encoding="utf-8")
    sys.stderr = io.TextIOWrapper(io.BufferedWriter(io.FileIO(2, "w", closefd=False)),
                                  encoding="utf-8", errors="backslashreplace",
                                  line_buffering=True)


@contextlib.contextmanager
def _fresh_warnings():
    with warnings.catch_warnings():
        _default_warnings()
        yield


def _show_on_stderr(message, category, filename, lineno, file=None, line=None) -> None:
    """A warning as the interpreter prints it, on the ``sys.stderr`` of the moment."""
    sys.stderr.write(warnings.formatwarning(message, category, filename, lineno, line))


@contextlib.contextmanager
def _environment(env: dict[str, str] | None):
    before = dict(os.environ)
    os.environ.update(env or {})
    try:
        yield
    finally:
        os.environ.clear()
        os.environ.update(before)


@contextlib.contextmanager
def _working_directory(cwd: Path | str | None):
    before = os.getcwd()
    os.chdir(cwd or before)
    try:
        yield
    finally:
        os.chdir(before)


@contextlib.contextmanager
def _signal_handlers():
    before = {signum: signal.getsignal(signum) for signum in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for signum, handler in before.items():
            signal.signal(signum, handler)


@contextlib.contextmanager
def _standard_streams(stdin: bytes):
    """Descriptors 1 and 2 to temporary files and ``sys.std*`` on them; yields the files
    (stdout, stderr), read once this exits."""
    sys.stdout.flush()
    sys.stderr.flush()
    _flush_c_stdio()
    out, err, given = (tempfile.TemporaryFile() for _ in range(3))
    given.write(stdin)
    given.seek(0)
    saved_fds = {fd: os.dup(fd) for fd in (1, 2)}
    saved_streams = sys.stdin, sys.stdout, sys.stderr
    os.dup2(out.fileno(), 1)
    os.dup2(err.fileno(), 2)
    _interpreter_streams(given.fileno())
    try:
        yield out, err
    finally:
        for stream in (sys.stdout, sys.stderr):
            with contextlib.suppress(OSError, ValueError):
                stream.flush()
        _flush_c_stdio()
        for stream in (sys.stdin, sys.stdout, sys.stderr):
            with contextlib.suppress(OSError, ValueError):
                stream.close()
        sys.stdin, sys.stdout, sys.stderr = saved_streams
        for fd, saved in saved_fds.items():
            os.dup2(saved, fd)
            os.close(saved)
        given.close()


def run_cli(*args: str, stdin: bytes = b"", cwd: Path | str | None = None,
            env: dict[str, str] | None = None, text: bool = False) -> subprocess.CompletedProcess:
    """``feedtune ARGS`` in this process; never raises on exit status.

    Parameters
    ----------
    *args
        The command line after ``feedtune``.
    stdin
        Bytes on standard input.
    cwd
        Working directory meanwhile (None: this process's).
    env
        Environment variables added or changed meanwhile.
    text
        Decode stdout and stderr as UTF-8 (``text=True`` of ``subprocess.run``).

    Returns
    -------
    subprocess.CompletedProcess
        ``args`` as ``["feedtune", *args]``, ``returncode``, ``stdout``, ``stderr``.
    """
    with contextlib.ExitStack() as stack:
        stack.enter_context(_environment(env))
        stack.enter_context(_working_directory(cwd))
        stack.enter_context(_signal_handlers())
        stack.enter_context(_fresh_warnings())
        out, err = stack.enter_context(_standard_streams(stdin))
        try:
            code = run(list(args))
        except Exception:  # the interpreter prints it and exits 1
            traceback.print_exc()
            code = 1
        status, message = _exit_status(code)
        sys.stderr.write(message)
    out.seek(0)
    err.seek(0)
    stdout, stderr = out.read(), err.read()
    out.close()
    err.close()
    if text:
        stdout, stderr = stdout.decode("utf-8"), stderr.decode("utf-8")
    return subprocess.CompletedProcess(["feedtune", *args], status, stdout, stderr)


def _forked_command(main, args: list[str], cwd: str, stdin: str, stdout: str,
                    stderr: str) -> None:
    """The child of :func:`start_cli`: the process set up as ``python -m feedtune ARGS``
    started from this one would find it, then ``main`` (the command's own, which ends the
    process: :func:`feedtune.__main__.exit_without_teardown`)."""
    os.chdir(cwd)
    for fd, path, flags in ((0, stdin, os.O_RDONLY), (1, stdout, os.O_WRONLY),
                            (2, stderr, os.O_WRONLY)):
        opened = os.open(path, flags)
        os.dup2(opened, fd)
        os.close(opened)
    _interpreter_streams(0)
    # an executed interpreter: caught signals back to their defaults, ignored ones kept
    # ignored, and Python's KeyboardInterrupt for SIGINT
    for signum, default in ((signal.SIGINT, signal.default_int_handler),
                            (signal.SIGTERM, signal.SIG_DFL)):
        if signal.getsignal(signum) is not signal.SIG_IGN:
            signal.signal(signum, default)
    _default_warnings()
    logging.root.handlers.clear()  # pytest's capture: a record reaches stderr, as there
    sys.argv = [feedtune.__main__.__file__, *args]
    try:
        main()
    except BaseException as exc:  # noqa: BLE001 — as the interpreter ends on it
        traceback.print_exc()
        sys.stderr.flush()
        if isinstance(exc, KeyboardInterrupt):  # the interpreter's status: killed by SIGINT
            signal.signal(signal.SIGINT, signal.SIG_DFL)
            os.kill(os.getpid(), signal.SIGINT)
        os._exit(1)


class Command:
    """A ``feedtune ARGS`` process started by :func:`start_cli`: the part of
    :class:`subprocess.Popen` the tests use (``pid``, ``send_signal``, ``wait``,
    ``communicate``, ``returncode``: negative for a signal, as Popen's)."""

    def __init__(self, args: list[str], process, paths: list[str], text: bool):
        self.args, self._process, self._paths, self._text = args, process, paths, text
        self._outputs = None

    @property
    def pid(self) -> int:
        return self._process.pid

    @property
    def returncode(self) -> int | None:
        return self._process.exitcode

    def send_signal(self, signum: int) -> None:
        if self.returncode is None:  # not a pid that may be another process's by now
            os.kill(self.pid, signum)

    def wait(self, timeout: float | None = None) -> int:
        """The exit status once the process has ended; its stdout and stderr are then read
        and its three files removed."""
        self._process.join(timeout)
        if self.returncode is None:
            raise subprocess.TimeoutExpired(self.args, timeout)
        if self._outputs is None:
            _, *outputs = (Path(path).read_bytes() for path in self._paths)
            for path in self._paths:
                os.unlink(path)
            self._outputs = tuple(d.decode("utf-8") if self._text else d for d in outputs)
        return self.returncode

    def communicate(self, timeout: float | None = None) -> tuple:
        """(stdout, stderr) once the process has ended (bytes, or str with ``text``)."""
        self.wait(timeout)
        return self._outputs


def start_cli(*args: str, stdin: bytes = b"", cwd: Path | str | None = None,
              text: bool = False, main=None) -> Command:
    """``feedtune ARGS`` as a process of its own, forked from this one (spawned if this
    process runs other threads, as a batch's workers are:
    :func:`feedtune.batch.local.start_method`), for a test whose subject is the process (a
    signal or SIGKILL sent to it, its exit status and stderr when its Dask scheduler is lost
    or missing) but not a fresh interpreter's start. It runs ``feedtune.__main__.main``, the
    ``feedtune`` script's function, with ``stdin`` on standard input, stdout and stderr files
    of its own, the signal dispositions, warning filters and logging of a fresh interpreter,
    and this process's imports (and a batch's warm-up): ≈ 1.3 s of CPU less than a ``python
    -m feedtune`` process (tests/README.md). What a fresh interpreter does before the command
    (its imports, a signal while they load) is tested with ``subprocess``
    (tests/cli/test_startup_imports.py, the early signals of tests/batch/test_batch_cli.py).
    ``main``: the function the child runs instead of ``feedtune.__main__.main`` (a test of
    this helper's own; module-level, so that a spawned child finds it by name)."""
    from feedtune.batch.local import start_method

    paths = []
    for data in (stdin, b"", b""):  # stdin, stdout, stderr
        handle, path = tempfile.mkstemp(prefix="feedtune-cli-")
        with os.fdopen(handle, "wb") as file:
            file.write(data)
        paths.append(path)
    context = multiprocessing.get_context(start_method())
    process = context.Process(target=_forked_command, name="feedtune",
                              args=(main or feedtune.__main__.main, list(args),
                                    str(cwd or os.getcwd()), *paths))
    process.start()
    return Command(["feedtune", *args], process, paths, text)


def run_forked(*args: str, stdin: bytes = b"", cwd: Path | str | None = None,
               text: bool = False, timeout: float | None = None) -> subprocess.CompletedProcess:
    """:func:`start_cli` to its end: what ``subprocess.run(..., capture_output=True)`` returns."""
    command = start_cli(*args, stdin=stdin, cwd=cwd, text=text)
    stdout, stderr = command.communicate(timeout)
    return subprocess.CompletedProcess(command.args, command.returncode, stdout, stderr)
