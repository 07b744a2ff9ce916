#!/usr/bin/env python
"""Where a batch spec's time goes: the phases of ``feedtune.batch.job.solve`` per spec.

Runs ``solve`` (what a batch worker runs: parse, tune, validate, result JSON, summary row)
in this process on the first ``--specs`` specs of ``benchmarks/batch_throughput.py``'s
generated set, after one untimed solve of each kind, with one BLAS thread (as the
``feedtune`` command sets it). Each phase is timed by wrapping the function that does it
(inclusive CPU time of this single-threaded process, which a loaded machine inflates far
less than wall time; phases nest as indented), so the numbers add up to the total only
along one level. It also prints the solver-cache hit rate over the timed specs.

    .venv/bin/python benchmarks/batch_profile.py --specs 150
    FEEDTUNE_BENCH_TREE=/tmp/old .venv/bin/python benchmarks/batch_profile.py   # another tree
"""

from __future__ import annotations

import os

for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import argparse  # noqa: E402
import functools  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from collections import defaultdict  # noqa: E402
from pathlib import Path  # noqa: E402

#: the feedtune profiled: this checkout, or another tree (FEEDTUNE_BENCH_TREE, e.g. a
#: ``git archive`` of an older revision, as batch_throughput.py --baseline makes one)
TREE = Path(os.environ.get("FEEDTUNE_BENCH_TREE") or Path(__file__).resolve().parents[1])
sys.path.insert(0, str(TREE))
sys.path.insert(1, str(Path(__file__).resolve().parent))

import feedtune  # noqa: E402  (from TREE, before batch_throughput adds its own checkout)
from batch_throughput import generate, one_spec_per_structure  # noqa: E402

import feedtune.batch.job as job  # noqa: E402
import feedtune.problem as problem  # noqa: E402
import feedtune.schema.spec as spec_module  # noqa: E402
import feedtune.tuner.nlp as nlp  # noqa: E402
from feedtune.schema.result import TuneResult  # noqa: E402

try:  # the solver cache and the scalar search have their own modules since issue 15
    import feedtune.tuner.cache as cache  # noqa: E402
except ImportError:  # an older tree: all in nlp.py
    cache = nlp
try:
    from feedtune.tuner.scalar import ScalarSearch  # noqa: E402
except ImportError:
    ScalarSearch = None
try:  # the root search of one tunable and one |e| (h-bst6)
    from feedtune.tuner.roots import RootSearch  # noqa: E402
except ImportError:
    RootSearch = None

TOTALS: dict[str, float] = defaultdict(float)
CALLS: dict[str, int] = defaultdict(int)

#: (label, owner, attribute, depth): what is timed, in the order printed
PHASES = [
    ("solve (one batch spec)", job, "solve", 0),
    ("parse_spec", spec_module, "parse_spec", 1),
    ("tune", problem, "_tune_once", 1),
    ("report sets (which metrics)", problem, "_report_sets", 2),
    ("Problem.__init__ (graph, probe, solver)", nlp.Problem, "__init__", 2),
    ("symbolic loop and metric values (structure miss)", nlp, "build_structure", 3),
    # nlpsol: cache.make_solver since issue 15, nlp._nlpsol before (whichever the tree has)
    ("nlpsol creation (cache miss)", cache, "make_solver", 3),
    ("nlpsol creation (cache miss)", nlp, "_nlpsol", 3),
    ("structure key (serialize graph)", cache, "structure_key", 3),
    ("root search's grid (signed e at 17+ points)", RootSearch, "for_problem", 3),
    ("Problem.solve", nlp.Problem, "solve", 2),
    ("the starts (every method, the end's check)", nlp.Problem, "_run_start", 3),
    ("one start (restoration + IPOPT + exchange)", nlp.Problem, "_solve_from", 4),
    ("restoration / stability check", nlp.Problem, "_stable_start", 5),
    ("one start, scalar search (grid bracket + Brent)", ScalarSearch, "solve_from", 4),
    ("one start, root search (downhill, brentq)", RootSearch, "solve_from", 4),
    ("NLP check at each start's end", nlp.Problem, "_evaluate", 4),
    # the reduced Hessian: feedtune.tuner.optimum.flat_tunables (called from nlp) since
    # issue 15, Problem._flat_tunables before; the scalar search's curvature test
    ("flat directions (reduced Hessian)", nlp, "flat_tunables", 3),
    ("flat directions (reduced Hessian)", nlp.Problem, "_flat_tunables", 3),
    ("flat directions (scalar search: curvature)", ScalarSearch, "flat_tunables", 3),
    ("exact evaluation + reports", nlp.Problem, "_evaluate_numeric", 3),
    ("validation", problem, "_validation", 2),
    ("plausibility warnings", problem, "plausibility_warnings", 2),
    ("result JSON (model_dump_json)", TuneResult, "model_dump_json", 1),
    ("summary row", job, "summary_fields", 1),
]


def _timed(label: str, fn):
    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        started = time.process_time()
        try:
            return fn(*args, **kwargs)
        finally:
            TOTALS[label] += time.process_time() - started
            CALLS[label] += 1

    return wrapper


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--specs", type=int, default=150)
    args = parser.parse_args(argv)
    specs = generate(max(args.specs, 300))
    for spec in one_spec_per_structure(specs):
        job.solve(json.dumps(spec).encode())
    for label, owner, name, _ in PHASES:
        if owner is not None and hasattr(owner, name):  # a tree has one of each pair
            setattr(owner, name, _timed(label, getattr(owner, name)))

    TOTALS.clear()
    CALLS.clear()
    cache.clear_solver_cache()
    data = [json.dumps(s).encode() for s in specs[:args.specs]]
    load = os.getloadavg()[0]
    started, cpu = time.perf_counter(), time.process_time()
    for d in data:
        job.solve(d)
    wall, cpu = time.perf_counter() - started, time.process_time() - cpu
    n = len(data)
    print(f"{n} specs in one process, feedtune from {TREE}: {cpu / n * 1e3:.1f} ms/spec CPU, "
          f"{wall / n * 1e3:.1f} ms/spec wall (timers included); load average {load:.2f} "
          f"before, {os.getloadavg()[0]:.2f} after")
    print()
    print("| phase | calls/spec | CPU ms/spec | share |")
    print("|---|---|---|---|")
    total = TOTALS["solve (one batch spec)"] or cpu
    printed = set()
    for label, _, _, depth in PHASES:
        if CALLS.get(label) and label not in printed:
            printed.add(label)
            print(f"| {'. ' * depth}{label} | {CALLS[label] / n:.2f} | "
                  f"{TOTALS[label] / n * 1e3:.2f} | {TOTALS[label] / total:.0%} |")
    info = cache.solver_cache_info()
    hits, misses = info["hits"], info["misses"]
    print()
    print(f"solver cache over the timed specs: {hits} hits, {misses} misses "
          f"({hits / max(hits + misses, 1):.0%} hits)")
    if hasattr(cache, "structure_cache_info"):  # since issue 15's structure split
        info = cache.structure_cache_info()
        hits, misses = info["hits"], info["misses"]
        print(f"structure cache (graph not built) over the timed specs: {hits} hits, "
              f"{misses} misses ({hits / max(hits + misses, 1):.0%} hits)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
