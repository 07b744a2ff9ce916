"""tests/bytecode_cache.py: the process that starts the run writes the libraries' bytecode
once, and what it writes is what Python's own import reads (issue 15's test command)."""

from __future__ import annotations

import importlib.util
import json
import marshal
import sys
from pathlib import Path
from types import SimpleNamespace

import bytecode_cache


class FileCache:
    """pytest's cache as ``writing`` uses it (``get``, ``set`` of JSON by key), in a folder:
    the forked processes write to it as to ``.pytest_cache``, and the run's own is left
    alone."""

    def __init__(self, root: Path):
        self.root = root

    def get(self, key, default):
        path = self.root / key
        return json.loads(path.read_text()) if path.exists() else default

    def set(self, key, value):
        path = self.root / key
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(value))


def _read_by_import(source: Path):
    """The code in ``source``'s ``__pycache__`` file if Python's import would use it (the
    header's magic number, flags, source modification time and size match), else None."""
    cached = Path(importlib.util.cache_from_source(str(source)))
    if not cached.exists():
        return None
    data = cached.read_bytes()
    stat = source.stat()
    if (data[:4] != importlib.util.MAGIC_NUMBER or int.from_bytes(data[4:8], "little") != 0
            or int.from_bytes(data[8:12], "little") != int(stat.st_mtime) & 0xFFFFFFFF
            or int.from_bytes(data[12:16], "little") != stat.st_size & 0xFFFFFFFF):
        return None
    return marshal.loads(data[16:])


def test_writing_writes_what_an_import_reads_once(tmp_path, monkeypatch):
    """A package imported by a group (its ``__init__`` importing a submodule) and a module
    this process loaded without bytecode: each gets the bytecode an import reads, equal to
    its compiled source; a module the import does not load gets none; this process neither
    imports the package nor changes its setting; a second run with every recorded file's
    bytecode present starts no process, one with a file's bytecode gone writes it again,
    and without pytest's cache nothing is done."""
    site = tmp_path / "site"
    package = site / "tinst_bytecode_pkg"
    package.mkdir(parents=True)
    (package / "__init__.py").write_text("from . import core\n")
    (package / "core.py").write_text("X = 1\n")
    (package / "extra.py").write_text("Y = 2\n")
    loaded = site / "tinst_bytecode_loaded.py"
    loaded.write_text("Z = 3\n")
    monkeypatch.syspath_prepend(str(site))
    monkeypatch.setattr(sys, "dont_write_bytecode", True)
    # only this test's modules: the worker's own modules without bytecode (the libraries
    # it imported after the run's start, ≈ 0.4–3.5 s of compiling) are not what is tested,
    # and compiling them would write into the installation
    loaded_sources = bytecode_cache._loaded_sources
    monkeypatch.setattr(bytecode_cache, "_loaded_sources", lambda: [
        source for source in loaded_sources() if Path(source).is_relative_to(site)])
    config = SimpleNamespace(cache=FileCache(tmp_path / "cache"))
    importlib.import_module("tinst_bytecode_loaded")
    try:
        assert _read_by_import(loaded) is None
        with bytecode_cache.writing(config, [["tinst_bytecode_pkg"]]) as processes:
            assert processes == 1
    finally:
        del sys.modules["tinst_bytecode_loaded"]
    written = [package / "__init__.py", package / "core.py", loaded]
    for source in written:
        assert _read_by_import(source) == compile(source.read_text(), str(source), "exec",
                                                      dont_inherit=True)
    assert _read_by_import(package / "extra.py") is None
    assert "tinst_bytecode_pkg" not in sys.modules and sys.dont_write_bytecode
    assert {str(source) for source in written} <= set(config.cache.get(bytecode_cache.KEY, []))

    with bytecode_cache.writing(config, [["tinst_bytecode_pkg"]]) as processes:
        assert processes == 0
    Path(importlib.util.cache_from_source(str(package / "core.py"))).unlink()
    with bytecode_cache.writing(config, [["tinst_bytecode_pkg"]]) as processes:
        assert processes == 1
    assert _read_by_import(package / "core.py") is not None
    Path(importlib.util.cache_from_source(str(package / "core.py"))).unlink()
    with bytecode_cache.writing(SimpleNamespace(), [["tinst_bytecode_pkg"]]) as processes:
        assert processes == 0
    assert _read_by_import(package / "core.py") is None
