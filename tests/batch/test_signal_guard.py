"""tests/signal_guard.py: a test that leaves SIGINT ignored or blocked errors at its own
teardown, and the tests after it in the same process find the interpreter's handling.

Run in a pytest process of its own (the plugin alone, on three throw-away tests), since
what is tested is the state a test process keeps from one test to the next.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

TESTS = Path(__file__).resolve().parents[1]

LEAKING = '''
import signal

def test_leaves_sigint_ignored():
    signal.signal(signal.SIGINT, signal.SIG_IGN)

def test_leaves_sigint_blocked():
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})

def test_after_them():
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    assert signal.SIGINT not in signal.pthread_sigmask(signal.SIG_BLOCK, [])
'''


def test_a_test_leaving_sigint_ignored_or_blocked_errors_and_is_undone(tmp_path):
    (tmp_path / "pytest.ini").write_text("[pytest]\n")  # not the suite's addopts
    (tmp_path / "test_leaking.py").write_text(LEAKING)
    done = subprocess.run([sys.executable, "-m", "pytest", "-p", "signal_guard", "-p",
                           "no:cacheprovider", "-rA", "test_leaking.py"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120,
                          env={"PYTHONPATH": str(TESTS), "PATH": ""})
    lines = done.stdout.splitlines()
    assert "PASSED test_leaking.py::test_after_them" in lines, done.stdout
    for name, left in (("ignored", "'SIGINT': '<built-in function default_int_handler> -> "
                                   "<Handlers.SIG_IGN: 1>'"),
                       ("blocked", "'blocked': 'frozenset() -> frozenset({<Signals.SIGINT: "
                                   "2>})'")):
        assert any(line.startswith(f"ERROR test_leaking.py::test_leaves_sigint_{name} ")
                   for line in lines), done.stdout
        assert (f"AssertionError: test_leaking.py::test_leaves_sigint_{name} left the "
                f"process's signal handling changed (put back now): {{{left}}}"
                in done.stdout), done.stdout
