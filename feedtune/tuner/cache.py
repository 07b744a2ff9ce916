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


_cache: OrderedDict[str, Built] = OrderedDict()
_cache_counts = {"hits": 0, "misses": 0}
_cache_lock = threading.Lock()  # the dicts and counters only; a build runs unlocked
_structures: OrderedDict[str, object] = OrderedDict()
_structure_counts = {"hits": 0, "misses": 0}


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
        _structure_counts.update(hits=0, misses=0)


def cached_structure(key: str | None):
    """The structure (feedtune.tuner.structure.Structure) stored under ``key``, or None
    (always None without a key)."""
    if key is None:
        return None
    with _cache_lock:
        found = _structures.get(key)
        _structure_counts["hits" if found is not None else "misses"] += 1
        if found is not None:
            _structures.move_to_end(key)
        return found


def store_structure(key: str | None, structure) -> None:
    """Keep ``structure`` under ``key`` (nothing without a key)."""
    if key is None:
        return
    with _cache_lock:
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
