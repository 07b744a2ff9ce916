"""A pytest plugin (loaded by tests/conftest.py): every test leaves SIGINT's and SIGTERM's
handlers and the main thread's signal mask as it found them.

A test that changes them and does not put them back (or a command it runs in process:
``feedtune batch`` installs its own handlers) errors at its teardown, naming what it
left, and the state from before is put back, so the tests after it in the same process
run with the handlers a fresh interpreter has. Without this, a leak shows up later and
elsewhere: a Ctrl-C test whose re-raised SIGINT reaches an ignoring handler, or a
remembering one that never raises, fails with "the Ctrl-C should have stopped the batch
by now" (tests/batch/test_batch_cli.py), far from the test that left it.
"""

from __future__ import annotations

import signal
import threading

import pytest

SIGNALS = (signal.SIGINT, signal.SIGTERM)
_BEFORE = pytest.StashKey[dict]()


def signal_state() -> dict | None:
    """The handlers of SIGNALS and the blocked signals of this thread; None off the main
    thread (where neither can be set)."""
    if threading.current_thread() is not threading.main_thread():
        return None
    state = {signal.Signals(signum).name: signal.getsignal(signum) for signum in SIGNALS}
    state["blocked"] = frozenset(signal.pthread_sigmask(signal.SIG_BLOCK, []))
    return state


def restore(state: dict) -> None:
    for signum in SIGNALS:
        signal.signal(signum, state[signal.Signals(signum).name])
    signal.pthread_sigmask(signal.SIG_SETMASK, state["blocked"])


@pytest.hookimpl(wrapper=True, tryfirst=True)
def pytest_runtest_setup(item):
    item.stash[_BEFORE] = signal_state()  # before any fixture of this test is set up
    return (yield)


@pytest.hookimpl(wrapper=True, tryfirst=True)
def pytest_runtest_teardown(item, nextitem):
    result = yield  # after every fixture this test finished with is torn down
    before, after = item.stash.get(_BEFORE, None), signal_state()
    if before is not None and after != before:
        restore(before)
        changed = {name: f"{before[name]!r} -> {after[name]!r}" for name in before
                   if after[name] != before[name]}
        raise AssertionError(f"{item.nodeid} left the process's signal handling changed "
                             f"(put back now): {changed}")
    return result
