"""Progress of a batch on stderr: a bar on a terminal, plain periodic lines otherwise."""

from __future__ import annotations

import sys
import time
from typing import TextIO

#: a line every this many seconds when stderr is not a terminal [s]
LINE_SECONDS = 10.0
#: the bar is redrawn at most this often [s]
BAR_SECONDS = 0.1


def _duration(seconds: float) -> str:
    seconds = int(round(seconds))
    return f"{seconds // 60}m{seconds % 60:02d}s" if seconds >= 60 else f"{seconds}s"


class Progress:
    """Counts finished specs and failures; ``update`` after each, ``close`` at the end."""

    def __init__(self, total: int, stream: TextIO | None = None, enabled: bool = True,
                 interactive: bool | None = None, every: float = LINE_SECONDS):
        self.total, self.done, self.failed = total, 0, 0
        self.stream = stream or sys.stderr
        self.enabled = enabled
        self.interactive = (interactive if interactive is not None
                            else hasattr(self.stream, "isatty") and self.stream.isatty())
        self.every = BAR_SECONDS if self.interactive else every
        self.started = time.monotonic()
        self._shown = -float("inf")

    def update(self, ok: bool) -> None:
        self.done += 1
        self.failed += not ok
        now = time.monotonic()
        if self.enabled and (now - self._shown >= self.every or self.done == self.total):
            self._shown = now
            self._show(now)

    def _text(self, now: float) -> str:
        elapsed = now - self.started
        rate = self.done / elapsed if elapsed > 0 else 0.0
        eta = (self.total - self.done) / rate if rate > 0 else 0.0
        percent = 100 * self.done / self.total if self.total else 100.0
        return (f"{self.done}/{self.total} specs ({percent:.0f} %), {self.failed} failed, "
                f"{rate:.3g} specs/s, elapsed {_duration(elapsed)}, left ~{_duration(eta)}")

    def _show(self, now: float) -> None:
        if self.interactive:
            width = 30
            filled = int(width * self.done / self.total) if self.total else width
            bar = "#" * filled + "-" * (width - filled)
            self.stream.write(f"\r[{bar}] {self._text(now)}\x1b[K")
        else:
            self.stream.write(f"progress: {self._text(now)}\n")
        self.stream.flush()

    def close(self) -> None:
        if self.enabled and self.interactive and self.done:
            self.stream.write("\n")
            self.stream.flush()
