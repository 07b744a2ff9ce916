"""A bounded map that forgets its least recently used entry, safe across threads (a Dask
worker runs specs in threads): the caches kept per loop structure in a process (a
structure's parametric twin, the Functions replayed on it; :mod:`feedtune.loops.twin`,
:mod:`feedtune.loops.frequency`)."""

from __future__ import annotations

import threading
from collections import OrderedDict
from typing import Hashable


class Lru:
    """At most ``size`` entries; reading or writing one makes it the most recently used."""

    def __init__(self, size: int):
        self.size = size
        self._entries: OrderedDict = OrderedDict()
        self._lock = threading.Lock()

    def get(self, key: Hashable, default=None):
        """The value kept under ``key``, or ``default``."""
        with self._lock:
            try:
                self._entries.move_to_end(key)
            except KeyError:
                return default
            return self._entries[key]

    def put(self, key: Hashable, value) -> None:
        """Keep ``value`` under ``key``, forgetting the least recently used beyond ``size``."""
        with self._lock:
            self._entries[key] = value
            self._entries.move_to_end(key)
            while len(self._entries) > self.size:
                self._entries.popitem(last=False)

    def items(self) -> list[tuple]:
        """The entries, least recently used first (a copy)."""
        with self._lock:
            return list(self._entries.items())

    def clear(self) -> None:
        with self._lock:
            self._entries.clear()

    def __len__(self) -> int:
        return len(self._entries)
