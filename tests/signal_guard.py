"""A pytest plugin (loaded by tests/conftest.py): every test leaves SIGINT's and SIGTERM's
handlers and the main thread's signal mask as it found them.

A test that changes them and does not put them back (or a command it runs in process:
``feedtune batch`` installs its own handlers) errors at its teardown, naming what it
left, and the state from before is put back, so the tests after it in the same process
run with the handlers a fresh interpreter has. Without this, a leak shows up later and
elsewhere: a Ctrl-C test whose re-raised SIGINT reaches an ignoring handler, or a
remembering one that never raises, fails with "the Ctrl-C should have stopped the batch
by now" (tests/batch/test_batch_cli.py), far from the test that left it.

The state includes what the kernel ignores (``SigIgn`` in /proc/self/status), which
``signal.getsignal`` does not show when C code changes it, and it is compared between
tests too: a change after one test's teardown and before the next one's setup (a plugin,
a session fixture, another thread) errors at the next test's setup, naming both. What the
suite starts with is not checked: a suite started in the background of a shell
(``pytest &``) has SIGINT and SIGQUIT ignored from its first line (POSIX), and the tests
that rely on Python's Ctrl-C handler install it themselves.
"""

from __future__ import annotations

import signal
import threading

import pytest

SIGNALS = (signal.SIGINT, signal.SIGTERM)
#: (number, name) of each of SIGNALS
_NAMED = tuple((signum, signal.Signals(signum).name) for signum in SIGNALS)
_BEFORE = pytest.StashKey[dict]()
#: (the state a test's teardown left, that test's node id), for the next test's setup
_LAST: list = [None, None]


def kernel_ignored() -> frozenset | None:
    """Which of SIGNALS the kernel ignores for this process (Linux), else None.

    The status file is read whole and its ``SigIgn:`` line found in the bytes (twice a
    test, ≈ 13 000 times a run): a state in 29–33 µs of CPU instead of 38–53 µs with the
    file split line by line in Python (load 12; benchmarks/README.md "Branch h-tdup")."""
    try:
        with open("/proc/self/status", "rb") as status:
            text = status.read()
    except OSError:
        return None
    start = text.find(b"\nSigIgn:")
    if start < 0:
        return None
    end = text.find(b"\n", start + 1)
    mask = int(text[start + len(b"\nSigIgn:"):end if end >= 0 else None], 16)
    return frozenset(name for signum, name in _NAMED if mask >> (signum - 1) & 1)


def signal_state() -> dict | None:
    """The handlers of SIGNALS, the blocked signals of this thread and which of SIGNALS the
    kernel ignores; None off the main thread (where the first two cannot be set)."""
    if threading.current_thread() is not threading.main_thread():
        return None
    state = {name: signal.getsignal(signum) for signum, name in _NAMED}
    state["blocked"] = frozenset(signal.pthread_sigmask(signal.SIG_BLOCK, []))
    state["kernel ignores"] = kernel_ignored()
    return state


def _changes(before: dict, after: dict) -> dict:
    return {name: f"{before[name]!r} -> {after[name]!r}" for name in before
            if after[name] != before[name]}


def restore(state: dict) -> None:
    for signum in SIGNALS:
        signal.signal(signum, state[signal.Signals(signum).name])
    signal.pthread_sigmask(signal.SIG_SETMASK, state["blocked"])


@pytest.hookimpl(wrapper=True, tryfirst=True)
def pytest_runtest_setup(item):
    before = item.stash[_BEFORE] = signal_state()  # before any fixture is set up
    last, after = _LAST
    if before is not None and last is not None and before != last:
        restore(last)
        item.stash[_BEFORE] = signal_state()
        raise AssertionError(f"the process's signal handling changed between {after}'s "
                             f"teardown and {item.nodeid}'s setup (put back now): "
                             f"{_changes(last, before)}")
    return (yield)


@pytest.hookimpl(wrapper=True, tryfirst=True)
def pytest_runtest_teardown(item, nextitem):
    result = yield  # after every fixture this test finished with is torn down
    before, after = item.stash.get(_BEFORE, None), signal_state()
    if before is not None and after != before:
        restore(before)
        _LAST[:] = signal_state(), item.nodeid
        raise AssertionError(f"{item.nodeid} left the process's signal handling changed "
                             f"(put back now): {_changes(before, after)}")
    _LAST[:] = after, item.nodeid
    return result
