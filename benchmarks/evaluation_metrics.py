#!/usr/bin/env python
"""A batch spec's exact evaluation (``Problem._evaluate_numeric``) per metric, replayed.

Solves the first ``--specs`` specs of ``benchmarks/batch_throughput.py``'s generated set
once in this process (one untimed solve of each kind first, one BLAS thread), keeping each
problem and the point its evaluation was called at; then replays those evaluations
``--rounds`` times on fresh loops, each part timed by wrapping (process CPU time): the
loop, the objective terms, the bounds, the conditions and matrices, and every report's
callable by metric name (the reports are evaluated together at the first request, so a
report's time is its own expression or numbers; the reports' one Function is its own row).
Every replay's numbers are compared with the first evaluation's (bit-equal, or the count
of differing entries is printed). With ``--profile`` a cProfile of the replays follows.

    .venv/bin/python benchmarks/evaluation_metrics.py --specs 120 --rounds 3
    FEEDTUNE_BENCH_TREE=/tmp/old .venv/bin/python benchmarks/evaluation_metrics.py   # another tree
"""

from __future__ import annotations

import os

for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import argparse  # noqa: E402
import cProfile  # noqa: E402
import dataclasses  # noqa: E402
import functools  # noqa: E402
import json  # noqa: E402
import pickle  # noqa: E402
import pstats  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from collections import defaultdict  # noqa: E402
from pathlib import Path  # noqa: E402

TREE = Path(os.environ.get("FEEDTUNE_BENCH_TREE") or Path(__file__).resolve().parents[1])
sys.path.insert(0, str(TREE))
sys.path.insert(1, str(Path(__file__).resolve().parent))

import feedtune  # noqa: E402, F401  (from TREE, before batch_throughput adds its own checkout)
from batch_throughput import generate, one_spec_per_structure  # noqa: E402

import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402

import feedtune.batch.job as job  # noqa: E402
import feedtune.problem as problem  # noqa: E402
import feedtune.tuner.nlp as nlp  # noqa: E402

KIND = bool(os.environ.get("EVALUATION_BY_KIND"))  # each report's time per loop class too
TOTALS: dict[str, float] = defaultdict(float)
CALLS: dict[str, int] = defaultdict(int)


def _timed(label, fn, by_kind=False):
    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        if by_kind and args:  # a report's callable: its loop's class beside the name
            return _timed(f"{label} [{type(args[0]).__name__}]", fn)(*args, **kwargs)
        started = time.process_time()
        try:
            return fn(*args, **kwargs)
        finally:
            TOTALS[label] += time.process_time() - started
            CALLS[label] += 1

    return wrapper


def _plain(value):
    """Numbers of an evaluation, for a bit-for-bit comparison."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tobytes()
    if isinstance(value, ca.DM):
        return np.asarray(value).tobytes()
    if isinstance(value, float):
        return np.float64(value).tobytes()
    return value


def _capture(data):
    captured = []
    original = nlp.Problem._evaluate_numeric

    def capture(self, values):
        out = original(self, values)
        captured.append((self, dict(values), _plain(out)))
        return out

    nlp.Problem._evaluate_numeric = capture
    try:
        for d in data:
            job.solve(d)
    finally:
        nlp.Problem._evaluate_numeric = original
    return captured


def _instrument(captured):
    """Every report's callable and the reports' one Function timed by metric name."""
    seen = set()
    for prob, _, _ in captured:
        if "make_loop" not in vars(prob).get("_timed_parts", ()):
            prob.make_loop = _timed("make_loop", prob.make_loop)
            prob._timed_parts = ("make_loop",)
            prob.objective_terms = [dataclasses.replace(
                t, value=_timed(f"objective {t.label.split('(')[0]}", t.value))
                for t in prob.objective_terms]
            prob.bounds = [dataclasses.replace(
                b, value=_timed(f"bound {b.label.split('(')[0]}", b.value)) for b in prob.bounds]
        reports = next(iter(prob.reports.values())).func.__self__ if prob.reports else None
        if reports is None or id(reports) in seen:
            continue
        seen.add(id(reports))
        for key, fn in list(reports.fns.items()):
            reports.fns[key] = _timed(f"report {key.split('(')[0]}", fn, KIND)
    problem.Reports._evaluate_all = _timed("reports together (_evaluate_all)",
                                           problem.Reports._evaluate_all)
    nlp.Problem._evaluate_numeric = _timed("_evaluate_numeric (the phase)",
                                           nlp.Problem._evaluate_numeric)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--specs", type=int, default=120)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--profile", type=int, default=0, help="cProfile rows to print")
    parser.add_argument("--dump", type=Path, help="write the first evaluations' numbers here "
                        "(pickle), to compare two trees' with --compare")
    parser.add_argument("--compare", type=Path, help="a --dump of another tree: count the "
                        "evaluations whose numbers differ from this tree's")
    args = parser.parse_args(argv)
    specs = generate(max(args.specs, 300))
    for spec in one_spec_per_structure(specs):
        job.solve(json.dumps(spec).encode())
    captured = _capture([json.dumps(s).encode() for s in specs[:args.specs]])
    firsts = [first for _, _, first in captured]
    if args.dump:
        args.dump.write_bytes(pickle.dumps(firsts))
    if args.compare:
        other = pickle.loads(args.compare.read_bytes())
        print(f"evaluations differing from {args.compare}: "
              f"{sum(a != b for a, b in zip(firsts, other))} of {len(firsts)}")
    _instrument(captured)
    profile = cProfile.Profile() if args.profile else None
    differ = 0
    load = os.getloadavg()[0]
    cpu = time.process_time()
    for _ in range(args.rounds):
        for prob, values, first in captured:
            if profile is not None:
                profile.enable()
            out = prob._evaluate_numeric(values)
            if profile is not None:
                profile.disable()
            differ += _plain(out) != first
    cpu = time.process_time() - cpu
    n = len(captured) * args.rounds
    print(f"{len(captured)} evaluations × {args.rounds} rounds, feedtune from {TREE}: "
          f"{cpu / n * 1e3:.2f} ms CPU an evaluation (timers included); load {load:.2f} → "
          f"{os.getloadavg()[0]:.2f}; replays differing from the first evaluation: {differ}")
    print()
    print("| part | calls/spec | CPU ms/spec |")
    print("|---|---|---|")
    for label, total in sorted(TOTALS.items(), key=lambda kv: -kv[1]):
        print(f"| {label} | {CALLS[label] / n:.2f} | {total / n * 1e3:.3f} |")
    if profile is not None:
        pstats.Stats(profile).sort_stats("tottime").print_stats(args.profile)
    return 0


if __name__ == "__main__":
    sys.exit(main())
