"""The batch's progress display: a redrawn bar on a terminal, periodic lines otherwise."""

import io

from feedtune.batch.progress import Progress


def test_plain_lines_when_not_a_terminal_and_always_a_last_one():
    stream = io.StringIO()
    progress = Progress(3, stream=stream, interactive=False, every=3600)
    for ok in (True, False, True):
        progress.update(ok)
    progress.close()
    lines = stream.getvalue().splitlines()
    assert lines[0].startswith("progress: 1/3 specs (33 %), 0 failed")  # the first at once
    assert lines[-1].startswith("progress: 3/3 specs (100 %), 1 failed")
    assert len(lines) == 2  # nothing in between within the hour
    assert "\r" not in stream.getvalue()


def test_a_bar_redrawn_in_place_on_a_terminal():
    stream = io.StringIO()
    progress = Progress(4, stream=stream, interactive=True)
    for _ in range(4):
        progress.update(True)
    progress.close()
    text = stream.getvalue()
    assert text.startswith("\r[") and "4/4 specs (100 %)" in text
    assert "[" + "#" * 30 + "]" in text and text.endswith("\n")


def test_quiet_prints_nothing():
    stream = io.StringIO()
    progress = Progress(2, stream=stream, enabled=False, interactive=True)
    progress.update(True)
    progress.update(True)
    progress.close()
    assert stream.getvalue() == ""
