"""feedtune.lru.Lru: the bounded map behind the per-structure caches (loops/twin.py,
loops/frequency.py)."""

from __future__ import annotations

import threading

from feedtune.lru import Lru


def test_it_forgets_the_least_recently_used_beyond_its_size():
    cache = Lru(2)
    cache.put("a", 1)
    cache.put("b", 2)
    assert cache.get("a") == 1  # now "b" is the least recently used
    cache.put("c", 3)
    assert cache.items() == [("a", 1), ("c", 3)]
    assert cache.get("b") is None and cache.get("b", False) is False
    assert len(cache) == 2


def test_writing_a_kept_key_makes_it_the_most_recent_and_falsy_values_are_kept():
    cache = Lru(2)
    cache.put("a", False)  # a cache's "not replayable" answer
    cache.put("b", 2)
    cache.put("a", 0)
    cache.put("c", 3)
    assert cache.items() == [("a", 0), ("c", 3)]
    assert cache.get("a", "missing") == 0
    cache.clear()
    assert cache.items() == [] and len(cache) == 0


def test_threads_writing_at_once_leave_it_within_its_size():
    cache = Lru(8)

    def write(offset: int) -> None:
        for i in range(2000):
            cache.put((offset, i % 50), i)
            cache.get((offset, (i * 7) % 50))

    threads = [threading.Thread(target=write, args=(t,)) for t in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert len(cache) == 8 and len(cache.items()) == 8
