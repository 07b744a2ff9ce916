"""What the test suite computes more than once: a pytest plugin and its summary (issue 15).

The plugin wraps, for the whole run, the calls whose repeats cost the suite's CPU:
``feedtune.problem.tune`` (and ``_tune_once``, each robust round and integer-ratio solve),
the tuner's ``Problem``/``SearchProblem`` construction, the validator
(``feedtune.validate.block.validate_result``), a report's drawing
(``feedtune.report.build_figures``), the python-control export
(``feedtune.loops.export.loop_to_control``), the command line run in the test process
(``feedtune.__main__.run``), and every process a test starts (``subprocess.Popen``,
``multiprocessing``'s ``Process.start``). Each call is a JSON line in ``$SUITE_REPEATS_OUT``
(default ``suite-repeats.jsonl``): what was called, a key of its input (the spec's canonical
JSON hashed, or the command line), the CPU it took with what it called (``process_time``),
the test and the process. A forked batch worker inherits the wrappers and writes its own
lines (its pid differs).

Run it beside the tests, from the repository root (``-n 0`` or with xdist)::

    SUITE_REPEATS_OUT=/tmp/rep.jsonl .venv/bin/python -m pytest -p benchmarks.suite_repeats tests/cli -n 0
    .venv/bin/python benchmarks/suite_repeats.py /tmp/rep.jsonl        # the repeats, by CPU

The summary lists, per kind of call, the keys called more than once in one test process,
with the files and tests that called them and the CPU of every call after the first (what
sharing one result per process could save at most; a later call may be cheaper than the
first because caches were warm). Times are CPU seconds of the calling process; a
subprocess's CPU is in ``benchmarks/pytest_cpu.py``'s children column, not here.
"""

from __future__ import annotations

import argparse
import collections
import functools
import hashlib
import json
import os
import sys
import time

_state = {"test": None, "path": None, "depth": collections.Counter()}


def _write(row: dict) -> None:
    row.update(test=_state["test"], pid=os.getpid())
    with open(_state["path"], "a") as out:
        out.write(json.dumps(row) + "\n")


def _hash(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def _spec_key(spec) -> tuple[str, str]:
    data = spec.model_dump(mode="json") if hasattr(spec, "model_dump") else spec
    return _hash(json.dumps(data, sort_keys=True, default=str)), str(data.get("name"))


def _result_key(result) -> tuple[str, str]:
    data = result.model_dump(mode="json") if hasattr(result, "model_dump") else result
    tuned = {k: v.get("value") for k, v in (data.get("tuned") or {}).items()}
    body = json.dumps([data.get("spec"), tuned], sort_keys=True, default=str)
    return _hash(body), str(data.get("name"))


def _wrap(owner, name: str, kind: str, key_of) -> None:
    original = getattr(owner, name)

    @functools.wraps(original)
    def wrapper(*args, **kwargs):
        try:
            key, label = key_of(*args, **kwargs)
        except Exception as exc:  # noqa: BLE001 — a key is a nicety, never an error
            key, label = "?", type(exc).__name__
        depth = _state["depth"][kind]
        _state["depth"][kind] += 1
        start = time.process_time()
        try:
            return original(*args, **kwargs)
        finally:
            _state["depth"][kind] -= 1
            _write({"kind": kind, "key": key, "label": label, "nested": depth,
                    "cpu": time.process_time() - start})

    setattr(owner, name, wrapper)
    # modules imported before this plugin's configure (the initial conftests, e.g.
    # tests/reference/conftest.py's ``from feedtune.problem import tune``) bound the
    # original by name: rebind theirs too
    for module in list(sys.modules.values()):
        for attribute, value in list(getattr(module, "__dict__", {}).items()):
            if value is original and module is not owner:
                setattr(module, attribute, wrapper)


def _argv_key(args) -> tuple[str, str]:
    text = " ".join(map(str, args)) if isinstance(args, (list, tuple)) else str(args)
    return _hash(text), text[:200]


def pytest_configure(config):
    """Wrap the calls (after tests/conftest.py pinned the BLAS threads, before any test
    module is imported)."""
    import multiprocessing.process
    import subprocess

    _state["path"] = os.environ.get("SUITE_REPEATS_OUT", "suite-repeats.jsonl")
    import feedtune.__main__ as main
    import feedtune.loops.export as export
    import feedtune.problem as problem
    import feedtune.report as report
    import feedtune.validate.block as block
    from feedtune.tuner.nlp import Problem
    from feedtune.tuner.search import SearchProblem

    _wrap(problem, "tune", "tune", lambda spec, *a, **k: _spec_key(spec))
    _wrap(problem, "_tune_once", "tune_once", lambda spec, *a, **k: _spec_key(spec))
    for cls in (Problem, SearchProblem):
        _wrap(cls, "__init__", "problem_init",
              lambda self, *a, structure_key=None, **k: (_hash(repr(structure_key)),
                                                         type(self).__name__))
    _wrap(block, "validate_result", "validate", _result_key)
    import feedtune.validate as validate
    validate.validate_result = block.validate_result
    _wrap(report, "build_figures", "figures", _result_key)
    _wrap(export, "loop_to_control", "export", lambda *a, **k: ("-", "loop_to_control"))
    _wrap(main, "run", "cli_run", lambda argv=None, *a, **k: _argv_key(argv or []))
    original_popen = subprocess.Popen.__init__

    def popen(self, args, *a, **k):
        key, label = _argv_key(args)
        _write({"kind": "popen", "key": key, "label": label, "nested": 0, "cpu": 0.0})
        return original_popen(self, args, *a, **k)

    subprocess.Popen.__init__ = popen
    original_start = multiprocessing.process.BaseProcess.start

    def start(self):
        _write({"kind": "process", "key": str(self.name), "label": str(self._target),
                "nested": 0, "cpu": 0.0})
        return original_start(self)

    multiprocessing.process.BaseProcess.start = start


def pytest_runtest_protocol(item, nextitem):
    _state["test"] = item.nodeid


def pytest_runtest_logfinish(nodeid, location):
    _state["test"] = None


def summarize(path: str, top: int) -> None:
    """Print, per kind, the keys called more than once in one process, largest repeat first."""
    rows = [json.loads(line) for line in open(path)]
    by_kind: dict[str, list] = collections.defaultdict(list)
    for row in rows:
        if row["nested"] == 0:
            by_kind[row["kind"]].append(row)
    for kind, calls in sorted(by_kind.items()):
        total = sum(r["cpu"] for r in calls)
        groups: dict[tuple, list] = collections.defaultdict(list)
        for r in calls:
            groups[(r["pid"], r["key"])].append(r)
        repeats = []
        for (_, key), group in groups.items():
            if len(group) > 1:
                extra = sum(r["cpu"] for r in group[1:])
                repeats.append((extra, key, group))
        repeats.sort(key=lambda item: -item[0])
        saved = sum(extra for extra, _, _ in repeats)
        print(f"\n## {kind}: {len(calls)} calls, {total:.1f} s; {len(groups)} distinct per "
              f"process; repeats {saved:.1f} s")
        for extra, key, group in repeats[:top]:
            tests = collections.Counter((r["test"] or "?").split("::")[0] for r in group)
            ids = sorted({(r["test"] or "?").split("::")[-1][:60] for r in group})
            print(f"  {extra:6.2f} s  {len(group):3d}x  {group[0]['label'][:70]}  [{key}]")
            print(f"           files {dict(tests)}")
            print(f"           tests {ids[:6]}{' …' if len(ids) > 6 else ''}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("path")
    parser.add_argument("--top", type=int, default=25)
    args = parser.parse_args()
    summarize(args.path, args.top)


if __name__ == "__main__":
    sys.exit(main())
