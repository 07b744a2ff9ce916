"""The libraries' bytecode that the test processes read, written once by the process that
starts the run, before the workers start.

The README's test command installs without ``--compile-bytecode``: uv would compile all
≈ 5 300 modules of the environment (16–22 s of CPU, ≈ 12 s of wall on 2 quiet
cores), of which the suite's processes import ≈ 1 700. With ``PYTHONDONTWRITEBYTECODE`` set (this
suite's CI, and the tests' own subprocesses) nothing would then write the bytecode of what
is imported, and every xdist worker, ``python -m feedtune`` and batch or Dask worker would
compile numpy's, scipy's and CasADi's modules again at each start.

:func:`writing` writes it instead, in the process that starts the run: it imports the
libraries the tests import (``groups``, one forked process a group, side by side, bytecode
writing on, so Python's own import writes each module's ``__pycache__`` file, atomically,
as an import in a process without ``PYTHONDONTWRITEBYTECODE`` would), and compiles the
modules the starting process has loaded already (pytest, its plugins: every worker imports
them before any conftest). The source files whose bytecode is then on disk are recorded in
pytest's cache (``.pytest_cache``); a later run whose recorded files all have their bytecode
does nothing (≈ 2 000 ``stat`` calls, 0.01 s of CPU). Without pytest's cache
(``-p no:cacheprovider``) or when a process's own setting already writes bytecode, nothing
is done. The cost in a fresh environment: 6.9–7.2 s of CPU in the two forked processes,
≈ 4.2 s of wall, at load 2.5 (10.4–11.2 s of CPU at load 10–22; ≈ 3–4 s of it the imports
themselves), against uv's 16–17 s of CPU and ≈ 12 s of wall (benchmarks/README.md, "Branch
h-tinst"). Bytecode that cannot
be written (a read-only installation) is left as it is: the modules are compiled in memory
at each import, as before.

The starting process itself imports nothing more (the forked processes end after their
imports), the test processes' own bytecode setting is left as it is, and what the workers
read is what their own import would have compiled: the bytecode of the same source, checked
against its modification time and size when read.
"""

from __future__ import annotations

import contextlib
import importlib
import os
import py_compile
import sys
from collections.abc import Callable, Iterator, Sequence
from importlib.machinery import SourceFileLoader
from importlib.util import cache_from_source

#: the key of pytest's cache under which the source files with written bytecode are kept
#: (and ``KEY-<n>``: the files the n-th process wrote)
KEY = "feedtune/bytecode"


def _loaded_sources() -> list[str]:
    """The source files of this process's modules that the plain source loader loaded (not
    extension modules, not the modules pytest's assertion rewriting loaded: those have their
    own cache, tests/rewrite_cache.py)."""
    files = set()
    for module in list(sys.modules.values()):
        spec = getattr(module, "__spec__", None)
        if spec is not None and isinstance(spec.loader, SourceFileLoader) and spec.origin:
            files.add(spec.origin)
    return sorted(files)


def _has_bytecode(source: str) -> bool:
    return os.path.exists(cache_from_source(source))


def _write(group: Sequence[str | Callable[[], object]],
           compile_first: Sequence[str]) -> list[str]:
    """Compile ``compile_first`` (source files), then import each module of ``group`` with
    bytecode writing on (or call it: a function that warms another cache of the run with
    what is imported before it); the loaded source files whose bytecode is on disk
    afterwards."""
    sys.dont_write_bytecode = False
    for source in compile_first:
        py_compile.compile(source, cfile=cache_from_source(source), quiet=2)
    for name in group:
        try:
            name() if callable(name) else importlib.import_module(name)
        except Exception:  # noqa: BLE001 -- a library that fails here fails in the tests
            continue
    return [source for source in _loaded_sources() if _has_bytecode(source)]


@contextlib.contextmanager
def writing(config, groups: Sequence[Sequence[str | Callable[[], object]]]) -> Iterator[int]:
    """Write the bytecode of what importing each of ``groups`` (module names, or functions
    to call after the names before them) loads, and of this process's loaded modules that
    have none, in one forked process a group, while the
    ``with`` block runs; recorded in pytest's cache when the block ends. Yields the number
    of processes started (0: the recorded files all have their bytecode, no pytest cache,
    or this process writes bytecode itself)."""
    cache = getattr(config, "cache", None)
    recorded = cache.get(KEY, None) if cache is not None else None
    if (cache is None or not sys.dont_write_bytecode or not groups
            or (recorded is not None and all(map(_has_bytecode, recorded)))):
        yield 0
        return
    loaded = [source for source in _loaded_sources() if not _has_bytecode(source)]
    children = []
    for index, group in enumerate(groups):
        cache.set(f"{KEY}-{index}", [])  # not an earlier run's, should this one's fail
        pid = os.fork()
        if pid == 0:  # imports its group, writing, records what it wrote, and ends
            try:
                cache.set(f"{KEY}-{index}", _write(group, loaded[index::len(groups)]))
            finally:
                os._exit(0)
        children.append(pid)
    try:
        yield len(children)
    finally:
        for pid in children:
            os.waitpid(pid, 0)
        written = set()
        for index in range(len(groups)):
            written.update(cache.get(f"{KEY}-{index}", []))
        cache.set(KEY, sorted(written))
