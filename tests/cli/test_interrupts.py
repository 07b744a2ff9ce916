"""No moment of a command's start where Ctrl-C or SIGTERM is not exit 130 (feedtune.interrupts).

The handlers that end the process with 130 while the command line loads must stay until
``batch`` installs its own (its first line), and must give way to the process's own
handlers before any other command runs; a gap between the two was where a SIGTERM under
load gave exit 143 (−15) and a Ctrl-C click's "Aborted!".
"""

import signal

from feedtune import interrupts
from feedtune.cli import batch, common
from feedtune.__main__ import run


def test_batch_takes_over_from_the_starting_handlers(monkeypatch, tmp_path):
    seen = {}
    original = batch._Stop.__init__

    def spy(self):
        seen["sigint"], seen["sigterm"] = (signal.getsignal(s) for s in interrupts.SIGNALS)
        original(self)

    monkeypatch.setattr(batch._Stop, "__init__", spy)
    before = [signal.getsignal(s) for s in interrupts.SIGNALS]
    code = run(["batch", str(tmp_path / "missing"), "--out", str(tmp_path / "out")])
    assert code == 2  # no such input: a usage error, after _Stop was made
    assert seen == {"sigint": interrupts.stop_while_starting,
                    "sigterm": interrupts.stop_while_starting}
    assert [signal.getsignal(s) for s in interrupts.SIGNALS] == before


def test_other_commands_run_with_the_process_handlers(monkeypatch, tmp_path):
    seen = {}
    original = common.read_spec

    def spy(spec):
        seen["handlers"] = [signal.getsignal(s) for s in interrupts.SIGNALS]
        return original(spec)

    monkeypatch.setattr(common, "read_spec", spy)
    before = [signal.getsignal(s) for s in interrupts.SIGNALS]
    run(["validate", str(tmp_path / "missing.json")])
    assert seen["handlers"] == before
    assert [signal.getsignal(s) for s in interrupts.SIGNALS] == before


def test_release_is_idempotent_and_restores_what_was_there():
    before = [signal.getsignal(s) for s in interrupts.SIGNALS]
    interrupts.hold()
    interrupts.hold()  # a second hold must not remember the starting handler as "before"
    assert signal.getsignal(signal.SIGTERM) is interrupts.stop_while_starting
    interrupts.release()
    interrupts.release()
    assert [signal.getsignal(s) for s in interrupts.SIGNALS] == before
