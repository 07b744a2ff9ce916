"""tests/signal_guard.py: a test that leaves SIGINT ignored or blocked errors at its own
teardown, and the tests after it in the same process find the interpreter's handling.

Run in a pytest process of its own (the plugin alone, on six throw-away tests: three for
each test below, which read that one run's report), since what is tested is the state a
test process keeps from one test to the next.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

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


#: a plugin that ignores SIGINT after test_first's teardown, outside every test
BETWEEN = '''
import signal

def pytest_runtest_logfinish(nodeid, location):
    if nodeid.endswith("test_first"):
        signal.signal(signal.SIGINT, signal.SIG_IGN)
'''

BETWEEN_TESTS = '''
import signal

def test_first():
    pass

def test_second():
    pass

def test_third():
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
'''


def _pytest(tmp_path, tests: str) -> subprocess.CompletedProcess:
    """pytest with the guard alone on ``tests`` in a process of its own, which starts with
    the interpreter's own SIGINT handler whatever its parent has (a suite started with
    `pytest &` has SIGINT ignored, which a child inherits). The installed plugins are not
    loaded (hypothesis's and xdist's: ≈ 0.25 s of CPU a process), only the guard."""
    (tmp_path / "pytest.ini").write_text("[pytest]\n")  # not the suite's addopts
    (tmp_path / "test_leaking.py").write_text(tests)
    start = ("import signal, sys, pytest; signal.signal(signal.SIGINT, "
             "signal.default_int_handler); sys.exit(pytest.main(sys.argv[1:]))")
    return subprocess.run([sys.executable, "-c", start, "-p", "signal_guard", "-p",
                           "no:cacheprovider", "-rA", "test_leaking.py"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120,
                          env={"PYTHONPATH": str(TESTS), "PATH": "",
                               "PYTEST_DISABLE_PLUGIN_AUTOLOAD": "1"})


@pytest.fixture(scope="module")
def guarded(tmp_path_factory) -> subprocess.CompletedProcess:
    """One pytest process of the guard on LEAKING's tests, then BETWEEN_TESTS' with the
    BETWEEN plugin (which acts only after ``test_first``), in one module: each test below
    reads its three tests' lines of the report (≈ 0.3 s of CPU a pytest process)."""
    root = tmp_path_factory.mktemp("guarded")
    (root / "between.py").write_text(BETWEEN)
    return _pytest(root, LEAKING + BETWEEN_TESTS + "\npytest_plugins = ['between']\n")


def test_a_test_leaving_sigint_ignored_or_blocked_errors_and_is_undone(guarded):
    done = guarded
    lines = done.stdout.splitlines()
    assert "PASSED test_leaking.py::test_after_them" in lines, done.stdout
    for name, left in (("ignored", "'SIGINT': '<built-in function default_int_handler> -> "
                                   "<Handlers.SIG_IGN: 1>', 'kernel ignores': \"frozenset() "
                                   "-> frozenset({'SIGINT'})\""),
                       ("blocked", "'blocked': 'frozenset() -> frozenset({<Signals.SIGINT: "
                                   "2>})'")):
        assert any(line.startswith(f"ERROR test_leaking.py::test_leaves_sigint_{name} ")
                   for line in lines), done.stdout
        assert (f"AssertionError: test_leaking.py::test_leaves_sigint_{name} left the "
                f"process's signal handling changed (put back now): {{{left}}}"
                in done.stdout), done.stdout


def test_a_change_between_two_tests_errors_at_the_next_setup_and_is_undone(guarded):
    """What no test's own setup–teardown window sees (a plugin, a session fixture's
    finaliser, C code changing what the kernel ignores) errors at the next test's setup."""
    done = guarded
    lines = done.stdout.splitlines()
    assert "PASSED test_leaking.py::test_first" in lines, done.stdout
    assert "PASSED test_leaking.py::test_third" in lines, done.stdout
    assert any(line.startswith("ERROR test_leaking.py::test_second ") for line in lines), \
        done.stdout
    assert ("the process's signal handling changed between test_leaking.py::test_first's "
            "teardown and test_leaking.py::test_second's setup (put back now): {'SIGINT': "
            "'<built-in function default_int_handler> -> <Handlers.SIG_IGN: 1>', "
            "'kernel ignores': \"frozenset() -> frozenset({'SIGINT'})\"}") in done.stdout, \
        done.stdout
