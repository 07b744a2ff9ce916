"""Assertion rewriting of the test modules done once per run, not once per xdist worker.

pytest rewrites each test module's ``assert`` statements (its detailed failure messages)
when the module is imported, and caches the rewritten code in the module's ``__pycache__``
(``*-pytest-<version>.pyc``, checked against the source's hash when read) unless
``PYTHONDONTWRITEBYTECODE`` is set, as it is in this suite's CI and the tests' own
subprocesses. Every xdist worker collects the whole suite, so on a fresh clone each worker
rewrote every test module: ≈ 6 s of CPU a worker at load 10, 40 % of its collection
(benchmarks/README.md, "Branch h-imp"). :func:`prewrite` writes those cached files in the
process that starts the run, before the workers start, split over the cores, with
pytest's own rewriting: the workers read them, so the rewritten code, and with it every
assertion message, is byte for byte what the workers would have made themselves.

The same holds for the pytest plugins' own modules: pytest rewrites every module of a
distribution that provides a plugin (hypothesis's ≈ 75 that the tests import, xdist's 6),
in every process, ≈ 1 s of CPU a worker at load 15 (benchmarks/README.md, "Branch
h-tunit"). With ``plugins=True``, :func:`prewrite` also writes their cached rewritten code
once: of the modules the starting process has rewritten itself (xdist's, hypothesis's
plugin), and of those a plain import of each plugin package loads (``hypothesis``), by
importing them in a forked process that lets pytest's own import hook write its cache.

Only pytest's private ``_pytest.assertion.rewrite`` functions do this; where they are
missing or differ (another pytest), nothing is written and each worker rewrites as before.
"""

from __future__ import annotations

import fnmatch
import importlib
import os
import sys
from pathlib import Path


def _modules(config) -> list[Path]:
    """The test modules and conftest files under the run's arguments (files or folders):
    those pytest rewrites (``python_files`` patterns and ``conftest.py``)."""
    patterns = [*config.getini("python_files"), "conftest.py"]
    found = set()
    for argument in config.args:
        path = Path(config.invocation_params.dir, argument.split("::")[0])
        candidates = path.rglob("*.py") if path.is_dir() else [path]
        found.update(p.resolve() for p in candidates
                     if p.suffix == ".py" and any(fnmatch.fnmatch(p.name, pat) for pat in patterns))
    return sorted(found)


def _plugin_modules(hook) -> tuple[list[Path], list[str]]:
    """What the plugins' modules need, from pytest's import hook in this process: the files
    of the modules it has rewritten here (each also cached, or not, on disk), and the
    packages marked for rewriting (every plugin distribution's top-level names) that are not
    imported yet. Empty for a hook without these attributes (another pytest)."""
    rewritten = getattr(hook, "_rewritten_names", None)
    marked = getattr(hook, "_must_rewrite", None)
    if rewritten is None or marked is None:
        return [], []
    return sorted(set(rewritten.values())), sorted(set(marked).difference(sys.modules))


def _import_writing(names: list[str]) -> None:
    """Import each of ``names`` with bytecode writing on, so that pytest's import hook writes
    the rewritten code of every marked module the import loads (in a forked process, which
    ends after it: the starting process's modules and settings are left as they were)."""
    sys.dont_write_bytecode = False
    for name in names:
        try:
            importlib.import_module(name)
        except Exception:  # noqa: BLE001 -- a plugin package that fails here fails in the run
            continue


def prewrite(config, processes: int | None = None, plugins: bool = False) -> int:
    """Write pytest's cached rewritten code of every test module of this run whose cache is
    missing or stale, in ``processes`` forked processes (default: one per core); the number
    of test modules written. With ``plugins``, also the plugin distributions' modules
    (:func:`_plugin_modules`): the stale ones this process rewrote, with the test modules,
    and the packages not imported yet, imported in one more forked process
    (:func:`_import_writing`). Nothing when assertions are not rewritten
    (``--assert=plain``)."""
    if config.getoption("assertmode") != "rewrite":
        return 0
    try:
        from _pytest.assertion.rewrite import (PYC_TAIL, _read_pyc, _rewrite_test, _write_pyc,
                                               assertstate_key, get_cache_dir)
    except ImportError:  # another pytest: its workers rewrite as they import
        return 0
    state = config.stash[assertstate_key]

    def is_stale(fn: Path) -> bool:
        return _read_pyc(fn, get_cache_dir(fn) / (fn.name[:-3] + PYC_TAIL)) is None

    stale = [fn for fn in _modules(config) if is_stale(fn)]
    written = len(stale)
    unimported = []
    if plugins:
        rewritten, unimported = _plugin_modules(config.pluginmanager.rewrite_hook)
        stale += [fn for fn in rewritten if fn not in stale and is_stale(fn)]
    processes = max(1, min(processes or os.cpu_count() or 1, len(stale)))

    def write(share: list[Path]) -> None:
        for fn in share:
            cache = get_cache_dir(fn)
            try:
                cache.mkdir(exist_ok=True)
                source_hash, code = _rewrite_test(fn, config)
            except (OSError, SyntaxError):  # unwritable, or not Python: pytest reports it
                continue
            _write_pyc(state, code, source_hash, cache / (fn.name[:-3] + PYC_TAIL))

    children = []
    if unimported:
        pid = os.fork()
        if pid == 0:  # imports the plugin packages, its hook writing, and ends
            try:
                _import_writing(unimported)
            finally:
                os._exit(0)
        children.append(pid)
    for index in range(1, processes):
        pid = os.fork()
        if pid == 0:  # a child writes its share and ends without pytest's teardown
            try:
                write(stale[index::processes])
            finally:
                os._exit(0)
        children.append(pid)
    write(stale[0::processes])
    for pid in children:
        os.waitpid(pid, 0)
    return written
