"""A bug inside ``feedtune tune`` or ``feedtune identify`` is exit 3 with the traceback on
stderr and one line naming feedtune's version, the exception and what to report it with
(feedtune.cli.common.internal_error, shared by both commands)."""

from __future__ import annotations

from pathlib import Path

import pytest

from feedtune import __version__
from feedtune_cli import run_cli

REPO = Path(__file__).resolve().parents[2]


def boom(*args, **kwargs):
    raise RuntimeError("boom")


@pytest.mark.parametrize("command, patched, send", [
    (["tune", "examples/koren-1979-reference-pulse.json"], "feedtune.api.tune", "the spec"),
    (["identify", "examples/data/hydraulic-frf-1.csv", "--model", "hydraulic_rotary"],
     "feedtune.measured.identify.identify", "the data")])
def test_a_bug_is_exit_3_naming_the_version(monkeypatch, command, patched, send):
    module, _, name = patched.rpartition(".")
    monkeypatch.setattr(__import__(module, fromlist=[name]), name, boom)
    proc = run_cli(*command, cwd=REPO)
    assert proc.returncode == 3
    text = proc.stderr.decode()
    assert "Traceback" in text and proc.stdout == b""
    assert (f"error: internal error in feedtune {__version__} (RuntimeError: boom); "
            f"please report it with {send}") in text
