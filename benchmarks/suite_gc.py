"""The test suite's garbage-collector settings (tests/conftest.py) against a baseline tree:
each xdist worker's start-up and collection, and the collector's own time while tests run.

Two measurements, each tree's run alternating with the baseline's in fresh pytest
processes started from this one (issue 15's test time):

- *collection*: ``pytest -n 2 -k <no test>`` with ``benchmarks/pytest_cpu.py``: both
  workers collect the whole suite and run nothing; the CPU each spent before its first test
  (interpreter, pytest and its plugins, conftest, every test module's import and items);
- *tests* (``--tests FILE ...``): ``pytest -n 0 FILE ...`` with a plugin that times every
  pass of the cyclic collector (``gc.callbacks``) from the end of collection to the end of
  the session, and the process's CPU.

Both trees run with this venv; the baseline's ``tests/conftest.py`` and test modules are
its own (``PYTHONPATH`` puts its feedtune first). CPU times on the shared cores vary by
±15 % between runs; the collector's time and its number of passes are the figures that
the load does not move much.

Run: ``.venv/bin/python benchmarks/suite_gc.py --baseline DIR [--rounds N]
[--tests tests/unit/test_solver_reuse.py ...]``
(DIR: e.g. ``git archive main | tar -x -C DIR``).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

#: a pytest plugin (written to a temporary directory): the collector's passes and time
#: after collection, and the process's CPU at the session's end, as one JSON line
GC_PLUGIN = '''
import gc, json, os, time
_passes, _spent, _start = [0, 0, 0], [0.0], [0.0]

def _callback(phase, info):
    if phase == "start":
        _start[0] = time.process_time()
    else:
        _spent[0] += time.process_time() - _start[0]
        _passes[info["generation"]] += 1

def pytest_collection_finish(session):
    gc.callbacks.append(_callback)

def pytest_sessionfinish(session):
    with open(os.environ["SUITE_GC_OUT"], "a") as out:
        out.write(json.dumps({"gc": _spent[0], "passes": _passes,
                              "threshold": gc.get_threshold(),
                              "cpu": time.process_time()}) + "\\n")
'''


def _env(tree: Path, **extra: str) -> dict:
    return {**os.environ, "PYTHONPATH": os.pathsep.join([str(tree), *extra.pop("path", [])]),
            "PYTHONDONTWRITEBYTECODE": "1", **extra}


def collection(tree: Path, scratch: Path) -> list[float]:
    """Each worker's CPU [s] before its first test, in a run of ``tree`` that runs none."""
    out = scratch / "collection.jsonl"
    out.unlink(missing_ok=True)
    subprocess.run([sys.executable, "-m", "pytest", "-p", "benchmarks.pytest_cpu", "-n", "2",
                    "-k", "zzz_no_such_test", "-p", "no:cacheprovider", "-q"],
                   cwd=tree, env=_env(tree, path=[str(REPO)], PYTEST_CPU_OUT=str(out)),
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False)
    rows = [json.loads(line) for line in out.read_text().splitlines()]
    return sorted(row["self"] for row in rows if row["kind"] == "collected")


def tests(tree: Path, scratch: Path, files: list[str]) -> dict:
    """The collector's time [s] and passes after collection, and the process's CPU [s],
    in ``pytest -n 0 FILES`` of ``tree``."""
    out = scratch / "gc.jsonl"
    out.unlink(missing_ok=True)
    subprocess.run([sys.executable, "-m", "pytest", "-p", "suite_gc_plugin", "-n", "0",
                    "-p", "no:cacheprovider", "-q", *files],
                   cwd=tree, env=_env(tree, path=[str(scratch)], SUITE_GC_OUT=str(out)),
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False)
    return json.loads(out.read_text().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", type=Path, required=True, help="another feedtune tree")
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--tests", nargs="*", default=[], help="test files for the gc timing")
    args = parser.parse_args()
    trees = {"baseline": args.baseline.resolve(), "this tree": REPO}
    with tempfile.TemporaryDirectory() as scratch:
        scratch = Path(scratch)
        (scratch / "suite_gc_plugin.py").write_text(GC_PLUGIN)
        for round_ in range(1, args.rounds + 1):
            for name, tree in trees.items():
                workers = collection(tree, scratch)
                print(f"round {round_} {name:9s}: workers' start-up and collection "
                      + " / ".join(f"{w:.2f}" for w in workers) + " s of CPU", flush=True)
            if not args.tests:
                continue
            for name, tree in trees.items():
                row = tests(tree, scratch, args.tests)
                print(f"round {round_} {name:9s}: tests' collector {row['gc']:.2f} s in "
                      f"{sum(row['passes'])} passes {row['passes']} at {row['threshold']}, "
                      f"process {row['cpu']:.1f} s of CPU", flush=True)


if __name__ == "__main__":
    main()
