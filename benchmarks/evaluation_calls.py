#!/usr/bin/env python
"""Where a batch spec's exact evaluation and validation go: cProfile and buffered calls.

Runs ``feedtune.batch.job.solve`` on the first ``--specs`` specs of
``benchmarks/batch_throughput.py``'s generated set in this process (one untimed solve of
each kind first, one BLAS thread) and reports, for ``Problem._evaluate_numeric`` and
``problem._validation`` only:

- their CPU a spec (process time), and a cProfile of just those two phases sorted by own
  time (``--top`` rows; cProfile's own cost inflates the Python rows about twofold);
- with ``--calls`` (a second pass, no profiler): every ``Buffered`` call (a CasADi
  Function through its evaluation buffer) timed whole and around its ``evaluate``
  (CasADi's VM), so the Python around the calls is the difference.

    .venv/bin/python benchmarks/evaluation_calls.py --specs 150 --calls
"""

from __future__ import annotations

import os

for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import argparse  # noqa: E402
import cProfile  # noqa: E402
import functools  # noqa: E402
import json  # noqa: E402
import pstats  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(1, str(Path(__file__).resolve().parent))

from batch_throughput import generate, one_spec_per_structure  # noqa: E402

import feedtune.batch.job as job  # noqa: E402
import feedtune.problem as problem  # noqa: E402
import feedtune.tuner.nlp as nlp  # noqa: E402
from feedtune.loops import frequency  # noqa: E402


def _profiled(data: list[bytes], top: int) -> None:
    profile = cProfile.Profile()
    cpu = {"exact evaluation + reports": 0.0, "validation": 0.0}

    def wrap(owner, name, label):
        fn = getattr(owner, name)

        @functools.wraps(fn)
        def wrapper(*args, **kwargs):
            started = time.process_time()
            profile.enable()
            try:
                return fn(*args, **kwargs)
            finally:
                profile.disable()
                cpu[label] += time.process_time() - started

        setattr(owner, name, wrapper)
        return owner, name, fn

    saved = [wrap(nlp.Problem, "_evaluate_numeric", "exact evaluation + reports"),
             wrap(problem, "_validation", "validation")]
    for d in data:
        job.solve(d)
    for owner, name, fn in saved:
        setattr(owner, name, fn)
    n = len(data)
    print(", ".join(f"{k} {v / n * 1e3:.2f} ms" for k, v in cpu.items()),
          f"CPU a spec under cProfile; load {os.getloadavg()[0]:.2f}")
    pstats.Stats(profile).sort_stats("tottime").print_stats(top)


def _buffered_calls(data: list[bytes]) -> None:
    clock = time.perf_counter
    totals = {"whole": 0.0, "evaluate": 0.0, "calls": 0}
    original = frequency.Buffered.__call__

    def timed(self, *args):  # Buffered.__call__ with a clock around its evaluate
        started = clock()
        _, evaluate, arguments, results = self._buffers.bound(lambda: self._fn)
        for target, value in zip(arguments, args):
            target[:] = value
        before = clock()
        evaluate()
        after = clock()
        out = [r.copy() for r in results]
        totals["whole"] += clock() - started
        totals["evaluate"] += after - before
        totals["calls"] += 1
        return out

    frequency.Buffered.__call__ = timed
    started = time.process_time()
    for d in data:
        job.solve(d)
    cpu = time.process_time() - started
    frequency.Buffered.__call__ = original
    n, calls = len(data), totals["calls"]
    print(f"Buffered calls: {calls / n:.1f} a spec, {totals['whole'] / calls * 1e6:.1f} µs a "
          f"call of which evaluate (CasADi) {totals['evaluate'] / calls * 1e6:.1f} µs; a spec: "
          f"{totals['whole'] / n * 1e3:.2f} ms in the calls, "
          f"{(totals['whole'] - totals['evaluate']) / n * 1e3:.3f} ms of it around evaluate "
          f"(whole spec {cpu / n * 1e3:.1f} ms CPU, timers included; load "
          f"{os.getloadavg()[0]:.2f})")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--specs", type=int, default=150)
    parser.add_argument("--top", type=int, default=40)
    parser.add_argument("--calls", action="store_true", help="also time the buffered calls")
    args = parser.parse_args(argv)
    specs = generate(max(args.specs, 300))
    for spec in one_spec_per_structure(specs):
        job.solve(json.dumps(spec).encode())
    data = [json.dumps(s).encode() for s in specs[:args.specs]]
    _profiled(data, args.top)
    if args.calls:
        _buffered_calls(data)
    return 0


if __name__ == "__main__":
    sys.exit(main())
