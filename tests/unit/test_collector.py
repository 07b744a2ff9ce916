"""feedtune.collector: the cyclic garbage collector held off while the command line starts
and while ``validate`` checks, and given back as it was (issue 15's start-up)."""

import gc
import subprocess
import sys

import pytest

from feedtune import collector


@pytest.fixture
def collector_on():
    """The collector on and nothing frozen before the test; so again after it."""
    was = gc.isenabled()
    gc.enable()
    yield
    collector.release()
    (gc.enable if was else gc.disable)()


@pytest.mark.parametrize("enabled", [True, False])
def test_hold_and_release_give_the_collector_back_as_it_was(collector_on, enabled):
    (gc.enable if enabled else gc.disable)()
    collector.hold()
    assert not gc.isenabled()
    collector.hold()  # a second hold remembers nothing new
    collector.release()
    assert gc.isenabled() == enabled
    collector.release()  # idempotent
    assert gc.isenabled() == enabled


@pytest.mark.parametrize("enabled", [True, False])
def test_paused_gives_the_collector_back_as_it_was_also_on_an_exception(collector_on, enabled):
    (gc.enable if enabled else gc.disable)()
    with pytest.raises(SystemExit), collector.paused():
        assert not gc.isenabled()
        raise SystemExit(2)  # how a command ends on a bad spec
    assert gc.isenabled() == enabled


def test_objects_allocated_meanwhile_move_to_the_oldest_generation(collector_on):
    """The first collection after the collector is back on does not walk them all (the
    young generations are empty), and a caller's own frozen objects stay frozen."""
    with collector.paused():
        kept = [[index] for index in range(5000)]
    assert gc.get_count()[0] < 100
    assert all(gc.is_tracked(item) for item in kept[:3])
    assert gc.get_freeze_count() == 0
    marker = [[]]  # the caller's, frozen below
    gc.freeze()
    try:
        with collector.paused():
            kept.append([[] for _ in range(10)])
        assert gc.get_freeze_count() > 0  # gc.unfreeze() would have emptied it
        assert all(item is not marker for item in gc.get_objects(generation=2))
    finally:
        gc.unfreeze()


#: the cycle test's body, run in a fresh interpreter: once the pause ends the cycle sits in
#: the oldest generation with every object of the process, so only a full collection frees
#: it, and in a test worker that walks the worker's whole heap (0.2–1.4 s of CPU in a full
#: run), in a fresh interpreter the few objects of ``feedtune.collector`` (≈ 0.05 s)
CYCLE_FREED = """
import gc, weakref
from feedtune import collector

class Node:
    pass

gc.enable()
with collector.paused():
    node = Node()
    node.self = node
    freed = weakref.ref(node)  # dead once the cycle is freed (not two scans of the heap)
    del node
    assert freed() is not None, "a cycle: only the collector frees it"
gc.collect()
assert freed() is None, "the cycle made while paused was not freed"
print("freed")
"""


def test_cyclic_garbage_made_while_paused_is_still_freed():
    out = subprocess.run([sys.executable, "-c", CYCLE_FREED], capture_output=True, text=True)
    assert (out.returncode, out.stdout.strip()) == (0, "freed"), out.stderr
