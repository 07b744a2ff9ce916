#!/usr/bin/env python
"""The starts and the tuned design's evaluation with and without compiled C, A/B in one
process: each call run twice on the same inputs, alternately in either order.

On ``batch_throughput.py``'s generated specs (``feedtune.batch.job.solve``, one BLAS
thread), every call of ``Problem._solve_from`` (one start: restoration, IPOPT, exchange
rounds) runs once with the usual IPOPT solvers and once with solvers built with
``nlpsol``'s ``jit`` (their NLP Functions and derivatives generated as C and compiled by
``cc -O2``; a separate solver cache, built in the warm-up), and every call of
``Problem._evaluate_numeric`` (the exact evaluation + reports) once with the replayed
Functions' rows evaluated by CasADi's virtual machine and once over the same Functions
compiled (``compiled_batch.compiled``: one library per Function, the row maps made over
it; with ``--rows`` one library per row length's map instead). The VM run's outcome is
the one returned; the two are compared (every array and number, to the bit). Two runs of
one call on one machine at one moment: the difference is the compiled code's, not the
load's.

    .venv/bin/python benchmarks/compiled_ab.py --specs 60
"""

from __future__ import annotations

import os

for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import threading  # noqa: E402
import time  # noqa: E402
from collections import OrderedDict, defaultdict  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))

import batch_profile  # noqa: E402  (puts the measured tree first on sys.path)
import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402
from batch_throughput import generate, one_spec_per_structure  # noqa: E402
from compiled_batch import STATS, compiled  # noqa: E402

import feedtune.batch.job as job  # noqa: E402
import feedtune.loops.frequency as frequency  # noqa: E402
import feedtune.tuner.cache as cache  # noqa: E402
import feedtune.tuner.nlp as nlp  # noqa: E402

MODE = ["vm"]
CPU: dict[tuple, float] = defaultdict(float)
DIFFERENT: dict[str, int] = defaultdict(int)
CALLS: dict[str, int] = defaultdict(int)
_caches = {"vm": cache._cache, "compiled": OrderedDict()}
_nlpsol = ca.nlpsol
JIT = {"jit": True, "compiler": "shell", "jit_cleanup": True,
       "jit_options": {"compiler": "cc", "flags": ["-O2"], "verbose": False}}
LIBRARIES = Path(tempfile.gettempdir()) / "feedtune-compiled-batch"


def nlpsol(name, plugin, problem, options=None):
    options = dict(options or {})
    if MODE[0] == "compiled":
        options.update(JIT)
    return _nlpsol(name, plugin, problem, options)


ROWS = [False]  # --rows: each row length's map compiled, not the Function mapped


def row(self, size):
    key = (threading.get_ident(), size, MODE[0])
    found = self._rows.get(key)
    if found is None:
        compiling = MODE[0] == "compiled"
        fn = compiled(self.fn, LIBRARIES) if compiling and not ROWS[0] else self.fn
        shared = [False] + [True] * (fn.n_in() - 1)
        fn = fn if size == 1 else fn.map(size, shared, [False] * fn.n_out())
        found = self._rows[key] = frequency.Buffered(
            compiled(fn, LIBRARIES) if compiling and ROWS[0] else fn)
    return found


def _same(a, b) -> bool:
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, (np.ndarray, float, int)) or a is None:
        return np.array_equal(np.asarray(a, dtype=float), np.asarray(b, dtype=float),
                              equal_nan=True) if a is not None else b is None
    return repr(a) == repr(b)


def ab(label: str, method, state=None):
    """``method`` run in both modes, alternately first; the VM run's result returned."""
    def wrapper(self, *args, **kwargs):
        CALLS[label] += 1
        order = ("vm", "compiled") if CALLS[label] % 2 else ("compiled", "vm")
        results = {}
        if state:
            self.__dict__.setdefault("_solvers_vm", self._solvers)
        for mode in order:
            MODE[0] = mode
            cache._cache = _caches[mode]
            if state:
                self.__dict__.setdefault(f"_solvers_{mode}", {})
                self._solvers = self.__dict__[f"_solvers_{mode}"]
            started = time.process_time()
            results[mode] = method(self, *args, **kwargs)
            CPU[label, mode] += time.process_time() - started
            if state:
                results[mode] = (results[mode], self._last_state, self._last_solver)
        MODE[0] = "vm"
        cache._cache = _caches["vm"]
        if state:
            self._solvers = self.__dict__["_solvers_vm"]
            self._last_state, self._last_solver = results["vm"][1], results["vm"][2]
            same = _same(results["vm"][0][:4], results["compiled"][0][:4])
            results = {mode: r[0] for mode, r in results.items()}
        else:
            same = _same(results["vm"], results["compiled"])
        DIFFERENT[label] += not same
        return results["vm"]
    return wrapper


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--specs", type=int, default=60)
    parser.add_argument("--rows", action="store_true",
                        help="compile each row length's map (one library a length)")
    args = parser.parse_args(argv)
    ROWS[0] = args.rows
    LIBRARIES.mkdir(parents=True, exist_ok=True)
    os.chdir(tempfile.mkdtemp(prefix="feedtune-jit-"))  # where CasADi's jit writes its C files
    ca.nlpsol = nlpsol
    frequency.Mapped._row = row
    nlp.Problem._solve_from = ab("one start", nlp.Problem._solve_from, state=True)
    nlp.Problem._evaluate_numeric = ab("exact evaluation + reports",
                                       nlp.Problem._evaluate_numeric)
    specs = generate(max(args.specs, 300))
    for spec in one_spec_per_structure(specs):  # builds and compiles each structure's
        job.solve(json.dumps(spec).encode())
    for spec in specs[:args.specs]:  # and any other structure among the measured specs
        job.solve(json.dumps(spec).encode())
    CPU.clear()
    DIFFERENT.clear()
    CALLS.clear()
    before = dict(STATS)
    load = os.getloadavg()[0]
    started = time.process_time()
    for spec in specs[:args.specs]:
        job.solve(json.dumps(spec).encode())
    cpu = time.process_time() - started
    n = args.specs
    print(f"{n} specs, {cpu / n * 1e3:.1f} ms/spec CPU with every start and evaluation run "
          f"twice; load {load:.2f} → {os.getloadavg()[0]:.2f}")
    print()
    print("| phase | calls/spec | VM ms/spec | compiled ms/spec | saved ms/spec | compiled/VM "
          "| calls with other results |")
    print("|---|---|---|---|---|---|---|")
    for label in ("one start", "exact evaluation + reports"):
        vm, c = CPU[label, "vm"] / n * 1e3, CPU[label, "compiled"] / n * 1e3
        print(f"| {label} | {CALLS[label] / n:.2f} | {vm:.2f} | {c:.2f} | {vm - c:.2f} | "
              f"{c / vm:.3f} | {DIFFERENT[label]} |")
    print()
    print("compilation in the measured specs: "
          + ", ".join(f"{k} {STATS[k] - before[k]:.2f}" if isinstance(STATS[k], float)
                      else f"{k} {STATS[k] - before[k]}" for k in STATS))
    return 0


if __name__ == "__main__":
    sys.exit(main())
