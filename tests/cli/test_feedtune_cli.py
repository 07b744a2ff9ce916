"""tests/feedtune_cli.py's ``run_cli`` gives what a ``python -m feedtune`` process gives: the
same exit status and bytes for the same command, C-level output on the right stream, an
escaping exception as a traceback and status 1, warnings as a fresh interpreter shows them,
and the test process left as it was (working directory, environment, signal handlers).
Its ``start_cli`` (a forked ``feedtune`` process) gives the same status and bytes too, with a
fresh interpreter's signal dispositions, warnings and logging."""

from __future__ import annotations

import ctypes
import os
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import pytest

import feedtune_cli
from feedtune_cli import run_cli, run_forked, start_cli

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "examples" / "koren-1979-sampled-data.json"


@pytest.mark.parametrize("args, stdin", [
    (["examples", "koren-1979-sampled-data"], b""),
    (["validate", "-"], b'{"name": "x", "plant": {"type": "software_servo"}}'),
    (["no-such-command"], b""),
], ids=["stdout", "exit-2-by-pointer", "usage-error"])
def test_the_same_status_and_bytes_as_a_process(args, stdin):
    process = subprocess.run([sys.executable, "-m", "feedtune", *args], input=stdin,
                             capture_output=True, cwd=REPO, timeout=120)
    in_process = run_cli(*args, stdin=stdin, cwd=REPO)
    forked = run_forked(*args, stdin=stdin, cwd=REPO, timeout=120)
    for proc in (in_process, forked):
        assert (proc.returncode, proc.stdout, proc.stderr) == (
            process.returncode, process.stdout, process.stderr)


def test_c_output_escaping_exceptions_and_warnings_are_seen(monkeypatch, tmp_path):
    libc = ctypes.CDLL(None)

    def command(args):
        libc.printf(b"from C\n")
        libc.fflush(None)
        print("from Python")
        warnings.warn("a user warning")  # shown by a fresh interpreter (default filters)
        warnings.warn("a deprecation", DeprecationWarning)  # hidden outside __main__
        assert os.getcwd() == str(tmp_path) and os.environ["FEEDTUNE_TEST_VAR"] == "1"
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        raise ValueError("escaped")

    monkeypatch.setattr(feedtune_cli, "run", command)
    cwd, handler = os.getcwd(), signal.getsignal(signal.SIGTERM)
    proc = run_cli("anything", cwd=tmp_path, env={"FEEDTUNE_TEST_VAR": "1"}, text=True)
    assert proc.returncode == 1
    assert proc.stdout == "from C\nfrom Python\n"
    assert "UserWarning: a user warning" in proc.stderr
    assert "a deprecation" not in proc.stderr
    assert "Traceback (most recent call last)" in proc.stderr
    assert proc.stderr.rstrip().endswith("ValueError: escaped")
    assert os.getcwd() == cwd and "FEEDTUNE_TEST_VAR" not in os.environ
    assert signal.getsignal(signal.SIGTERM) == handler


@pytest.mark.parametrize("code, status, message", [(None, 0, ""), (3, 3, ""), (-1, 255, ""),
                                                    ("stopped", 1, "stopped\n")])
def test_exit_codes_map_as_sys_exit_maps_them(monkeypatch, code, status, message):
    monkeypatch.setattr(feedtune_cli, "run", lambda args: code)
    proc = run_cli("anything", text=True)
    assert (proc.returncode, proc.stderr) == (status, message)


def _fresh_process_facts() -> None:
    """A ``main`` for the forked process: what it finds, on stdout; a warning and a log
    record, which a fresh interpreter prints on stderr; exit status 3."""
    import logging

    from feedtune.__main__ import exit_without_teardown

    names = {signal.default_int_handler: "KeyboardInterrupt", signal.SIG_DFL: "default",
             signal.SIG_IGN: "ignored"}
    print(os.getcwd(), sys.argv[1:], sys.stdin.read(),
          *(names.get(signal.getsignal(signum), "caught")
            for signum in (signal.SIGINT, signal.SIGTERM)))
    warnings.warn("a user warning")
    logging.getLogger("feedtune.test").warning("a log record")
    exit_without_teardown(3)


def _sleep() -> None:
    time.sleep(60)


def test_a_forked_command_starts_as_a_fresh_interpreter_would(tmp_path):
    """As an executed interpreter: a caught signal back to its default, Python's
    KeyboardInterrupt for SIGINT unless SIGINT is ignored (a suite started in the background
    of a shell, `pytest &`, inherits it ignored, and so would a `python` it starts)."""
    sigint = "ignored" if signal.getsignal(signal.SIGINT) is signal.SIG_IGN else "KeyboardInterrupt"
    previous = signal.signal(signal.SIGTERM, lambda signum, frame: None)  # this process's own
    try:
        command = start_cli("anything", stdin=b"given", cwd=tmp_path, text=True,
                            main=_fresh_process_facts)
    finally:
        signal.signal(signal.SIGTERM, previous)
    out, err = command.communicate(timeout=120)
    assert command.returncode == 3, err
    assert out == f"{tmp_path} ['anything'] given {sigint} default\n"
    assert "UserWarning: a user warning" in err and "a log record" in err


def test_a_forked_command_ends_by_the_signal_sent_to_it():
    command = start_cli("anything", main=_sleep)
    command.send_signal(signal.SIGKILL)
    assert command.wait(timeout=120) == -signal.SIGKILL
