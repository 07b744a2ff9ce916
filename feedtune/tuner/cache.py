"""The process-wide solver cache: one IPOPT solver and Function set per problem structure.

Building the IPOPT solver (``nlpsol``, SX expansion) costs more than most solves, and batch
tuning solves thousands of specs of a few structures in one process. Every number of a
problem that does not shape its graph is an NLP parameter (see feedtune.tuner.builder),
so two problems whose serialized graphs are equal can share one solver. The cache is keyed
by a hash of those graphs, the nlpsol options and the expand flag: a number still embedded
as a constant (a horizon's sample count, a frequency grid, the sign of a weight) makes a
different key.
"""

from __future__ import annotations

import hashlib
import json
import threading
from collections import OrderedDict
from dataclasses import dataclass
from typing import Mapping

import casadi as ca

#: built problems (nlpsol and Functions) kept per process, least recently used dropped first
SOLVER_CACHE_SIZE = 16
#: problem structures (symbolic loop, metric values, Functions; feedtune.tuner.structure)
#: kept per process by a key the caller computes from its spec, least recently used first out
STRUCTURE_CACHE_SIZE = 64


@dataclass
class Built:
    """What a problem structure costs to build: its Functions and its IPOPT solver."""

    functions: dict
    solver: object  # the nlpsol, or None without free tunables
    reused: bool = False


@dataclass(frozen=True)
class StructureKey:
    """A problem's structure as its caller knows it before building anything: ``shape``
    (text: everything that shapes the graph for certain) and ``embedded``, the numbers
    that may shape it, as (name, JSON text) pairs named as the loop attribute that holds
    each (feedtune.loops.loop.EmbeddedNumber).

    The first problem of a shape records which embedded numbers its graph read (the
    structure's ``embedded_reads``); whether a graph reads one is decided by its shape
    (which metrics, which technique), not by the numbers, so every later problem of that
    shape is found by those numbers alone: a loop without step integrals or frequency
    metrics shares one structure over every τ and period box.
    """

    shape: str
    embedded: tuple[tuple[str, str], ...] = ()

    def narrowed(self, reads) -> tuple:
        """The cache's key: the shape and the embedded numbers in ``reads`` (all of them
        when ``reads`` is None: a loop that records no reads)."""
        return (self.shape, tuple((name, value) for name, value in self.embedded
                                  if reads is None or name in reads))


_cache: OrderedDict[str, Built] = OrderedDict()
_cache_counts = {"hits": 0, "misses": 0}
_cache_lock = threading.Lock()  # the dicts and counters only; a build runs unlocked
_structures: OrderedDict[object, object] = OrderedDict()
_structure_counts = {"hits": 0, "misses": 0}
#: StructureKey.shape → the embedded numbers its graphs read (None: all)
_shape_reads: dict[str, frozenset | None] = {}


def solver_cache_info() -> dict[str, int]:
    """Hits, misses, current size and capacity of this process's solver cache."""
    return {**_cache_counts, "size": len(_cache), "maxsize": SOLVER_CACHE_SIZE}


def structure_cache_info() -> dict[str, int]:
    """Hits, misses, current size and capacity of this process's structure cache."""
    return {**_structure_counts, "size": len(_structures), "maxsize": STRUCTURE_CACHE_SIZE}


def clear_solver_cache() -> None:
    """Empty this process's solver and structure caches and reset their counters."""
    with _cache_lock:
        _cache.clear()
        _cache_counts.update(hits=0, misses=0)
        _structures.clear()
        _shape_reads.clear()
        _structure_counts.update(hits=0, misses=0)


def _stored_key(key: str | StructureKey):
    """The structure cache's key for ``key``: a StructureKey narrowed to the embedded
    numbers its shape's graphs read (None when no problem of that shape was stored yet),
    a text as it is."""
    if not isinstance(key, StructureKey):
        return key
    if key.shape not in _shape_reads:
        return None
    return key.narrowed(_shape_reads[key.shape])


def cached_structure(key: str | StructureKey | None):
    """The structure (feedtune.tuner.structure.Structure) stored under ``key``, or None
    (always None without a key)."""
    if key is None:
        return None
    with _cache_lock:
        stored = _stored_key(key)
        found = _structures.get(stored) if stored is not None else None
        _structure_counts["hits" if found is not None else "misses"] += 1
        if found is not None:
            _structures.move_to_end(stored)
        return found


def store_structure(key: str | StructureKey | None, structure) -> None:
    """Keep ``structure`` under ``key`` (nothing without a key), narrowed to the embedded
    numbers its graph read (``structure.embedded_reads``; None: all)."""
    if key is None:
        return
    with _cache_lock:
        if isinstance(key, StructureKey):
            reads = structure.embedded_reads
            _shape_reads[key.shape] = reads
            key = key.narrowed(reads)
        _structures[key] = structure
        while len(_structures) > STRUCTURE_CACHE_SIZE:
            _structures.popitem(last=False)


def structure_key(functions: Mapping[str, ca.Function], options: Mapping, expand: bool) -> str:
    """SHA-256 of the serialized Functions, the nlpsol options and the expand flag.

    Every number that is not an NLP parameter is a constant inside the serialized graph, so
    two problems share a key only when their solvers compute the same thing.
    """
    digest = hashlib.sha256()
    for name in sorted(functions):
        digest.update(name.encode())
        digest.update(functions[name].serialize().encode())
    digest.update(json.dumps([options, bool(expand)], sort_keys=True, default=repr).encode())
    return digest.hexdigest()


def make_solver(nlp: ca.Function, options: Mapping, expand: bool):
    """IPOPT on ``nlp``, expanded to SX when asked and possible."""
    if expand:
        try:
            return ca.nlpsol("feedtune", "ipopt", nlp, {**options, "expand": True})
        except RuntimeError:  # a node without an SX form (e.g. a rootfinder)
            pass
    return ca.nlpsol("feedtune", "ipopt", nlp, dict(options))


def cached_build(functions: dict, key_extra: Mapping[str, ca.Function], options: Mapping,
                 expand: bool, has_nlp: bool, key: str | None = None) -> Built:
    """The Functions and solver of this structure: from the cache when an identical graph
    was built before in this process, else ``functions`` with a new solver (then cached).

    ``key_extra`` are Functions that shape the problem without being used after the build
    (they enter the key only). Without free tunables there is no solver to build and
    nothing is cached. ``key``: :func:`structure_key` of these, when the caller has it.
    """
    if not has_nlp:
        return Built(functions, None)
    if key is None:
        key = structure_key({**functions, **key_extra}, options, expand)
    with _cache_lock:
        built = _cache.get(key)
        if built is not None:
            _cache.move_to_end(key)
            _cache_counts["hits"] += 1
            return Built(built.functions, built.solver, reused=True)
        _cache_counts["misses"] += 1
    built = Built(functions, make_solver(functions["nlp"], options, expand))
    with _cache_lock:
        _cache[key] = built
        while len(_cache) > SOLVER_CACHE_SIZE:
            _cache.popitem(last=False)
    return built
