"""The cyclic garbage collector off while the command line starts and while ``feedtune
validate`` checks its spec (issue 15's start-up).

Loading click and pydantic and building a spec's models allocates ≈ 10⁵ container objects
(classes, functions, schema dicts) that live as long as the process, and no cycle worth
collecting: the collections they start walk them again and again, and the first one after
the collector is back on walks all that were allocated meanwhile. Both cost ≈ 26 M of the
≈ 690 M instructions of ``feedtune validate`` (3.8 %; benchmarks/README.md, "Branch
h-vstart2"). :func:`hold` turns the collector off from the start of the command line
until :func:`release`, when the command is about to run (:mod:`feedtune.cli`'s group, as
:mod:`feedtune.interrupts`' signals); ``validate`` keeps it off while it checks
(:func:`paused`). Each time the collector comes back on, the objects allocated meanwhile
join its oldest generation (``gc.freeze`` then ``gc.unfreeze``), which it walks only at
its rare full collections, and still frees there. A tuning or a batch runs with the
collector as before. Light on purpose: imported before anything else of the command line.
"""

import contextlib
import gc
from collections.abc import Iterator

#: whether the collector was on at :func:`hold` (empty: nothing held)
_held: list[bool] = []


def _back_on(enabled: bool) -> None:
    """The objects allocated so far to the oldest generation, then the collector on if
    ``enabled``. A caller's own frozen objects (``gc.freeze``) stay frozen: then nothing is
    moved."""
    if gc.get_freeze_count() == 0:
        gc.freeze()
        gc.unfreeze()
    if enabled:
        gc.enable()


def hold() -> None:
    """The collector off from now until :func:`release` (whether it was on is remembered
    once)."""
    if not _held:
        _held.append(gc.isenabled())
        gc.disable()


def release() -> None:
    """The collector as it was before :func:`hold`; nothing if nothing is held
    (idempotent)."""
    if _held:
        _back_on(_held.pop())


@contextlib.contextmanager
def paused() -> Iterator[None]:
    """The collector off meanwhile, as it was after: for a command that checks one spec
    and ends (``feedtune validate``), not for a tuning, whose CasADi graphs make cycles."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        _back_on(enabled)
