"""tests/rewrite_cache.py: the controller writes pytest's rewritten test modules once, and
what it writes is what pytest itself would make and read (issue 15's collection time)."""

from __future__ import annotations

import sys

from _pytest.assertion.rewrite import PYC_TAIL, _read_pyc, _rewrite_test, get_cache_dir

import rewrite_cache


def test_prewrite_writes_what_pytest_reads_and_would_have_written(pytestconfig, tmp_path,
                                                                   monkeypatch):
    """Three test modules and a conftest under the run's one argument, a helper that is no
    test module beside them, split over two processes: each test module's cached code is
    read by pytest's own reader and equals pytest's own rewriting of it (the assertion
    messages with it); the helper is left alone; a second call finds nothing stale."""
    modules = []
    for name in ("test_a.py", "test_b.py", "sub/test_c.py", "conftest.py"):
        path = tmp_path / name
        path.parent.mkdir(exist_ok=True)
        path.write_text(f"def test_it():\n    x = {len(modules)}\n    assert x == 7, 'x'\n")
        modules.append(path)
    (tmp_path / "helper.py").write_text("assert True\n")
    monkeypatch.setattr(pytestconfig, "args", [str(tmp_path)])

    assert rewrite_cache.prewrite(pytestconfig, processes=2) == 4
    for path in modules:
        cached = _read_pyc(path, get_cache_dir(path) / (path.name[:-3] + PYC_TAIL))
        assert cached is not None, path
        assert cached == _rewrite_test(path, pytestconfig)[1], path
    assert not list(get_cache_dir(tmp_path / "helper.py").glob("helper*"))
    assert rewrite_cache.prewrite(pytestconfig, processes=2) == 0


def test_prewrite_writes_the_plugins_modules_the_run_will_import(pytestconfig, tmp_path,
                                                                 monkeypatch):
    """With ``plugins``: a package marked for rewriting (as pytest marks each plugin
    distribution's) and not imported yet gets every module its import loads cached, even with
    bytecode writing off, while this process's modules stay as they were; a module the hook
    already rewrote here gets its cache too; each is what pytest reads and its own rewriting;
    a module of the package that the import does not load is left alone; the test modules'
    count is unchanged (none under the run's argument)."""
    package = tmp_path / "site" / "tunit_marked_plugin"
    package.mkdir(parents=True)
    (package / "__init__.py").write_text("from . import core\nassert core.X == 1\n")
    (package / "core.py").write_text("X = 1\nassert X == 1, 'X'\n")
    (package / "extra.py").write_text("assert False\n")
    loaded = tmp_path / "site" / "already_rewritten.py"
    loaded.write_text("Y = 2\nassert Y == 2\n")
    (tmp_path / "run").mkdir()
    monkeypatch.syspath_prepend(str(tmp_path / "site"))
    monkeypatch.setattr(pytestconfig, "args", [str(tmp_path / "run")])
    monkeypatch.setattr(sys, "dont_write_bytecode", True)
    hook = pytestconfig.pluginmanager.rewrite_hook
    monkeypatch.setattr(hook, "_must_rewrite", {"tunit_marked_plugin"})
    monkeypatch.setattr(hook, "_marked_for_rewrite_cache", {})
    monkeypatch.setattr(hook, "_rewritten_names", {"already_rewritten": loaded})

    assert rewrite_cache.prewrite(pytestconfig, processes=2, plugins=True) == 0
    assert "tunit_marked_plugin" not in sys.modules
    for path in (package / "__init__.py", package / "core.py", loaded):
        cached = _read_pyc(path, get_cache_dir(path) / (path.name[:-3] + PYC_TAIL))
        assert cached is not None, path
        assert cached == _rewrite_test(path, pytestconfig)[1], path
    assert not list(get_cache_dir(package / "extra.py").glob("extra*"))
