"""tests/rewrite_cache.py: the controller writes pytest's rewritten test modules once, and
what it writes is what pytest itself would make and read (issue 15's collection time)."""

from __future__ import annotations

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
