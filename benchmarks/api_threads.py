#!/usr/bin/env python
"""``feedtune.tune(spec, threads=...)``: Bhatia's example with numpy/scipy's BLAS on one
thread against the default (one per core), side by side in one process.

A Python caller has usually imported numpy before feedtune, with OpenBLAS's default of one
thread per core (this script does so on purpose: the BLAS variables are removed before
numpy loads). Each round tunes ``examples/bhatia-1971-hydraulic.json`` with
``threads=1`` and with ``threads=None`` (left as loaded), alternating, after one warm-up
tuning (so both reuse the built solver); it prints wall and CPU time [s] per tuning, the
medians and their ratio, the bandwidth reached [rad/s] and the load average.

Usage::

    .venv/bin/python benchmarks/api_threads.py [--rounds 5]
"""

from __future__ import annotations

import os

for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.pop(_name, None)  # a caller's default: BLAS threads = cores

import argparse  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy  # noqa: E402,F401  (loaded before feedtune, as in a user's session)
from threadpoolctl import threadpool_info  # noqa: E402

import feedtune  # noqa: E402

SPEC = Path(__file__).resolve().parents[1] / "examples" / "bhatia-1971-hydraulic.json"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5, help="tunings per setting [count]")
    args = parser.parse_args()
    spec = feedtune.Spec.model_validate_json(SPEC.read_bytes())
    feedtune.tune(spec)  # warm-up: imports, and the solver built once
    default = sorted({pool["num_threads"] for pool in threadpool_info()
                      if pool["user_api"] == "blas"})
    print(f"BLAS threads as loaded: {default}; {os.cpu_count()} cores")
    times: dict[str, list[tuple[float, float]]] = {"threads=1": [], "threads=None": []}
    for _ in range(args.rounds):
        for label, threads in (("threads=1", 1), ("threads=None", None)):
            wall, cpu = time.perf_counter(), time.process_time()
            result = feedtune.tune(spec, threads=threads)
            wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
            times[label].append((wall, cpu))
            print(f"{label:13s} wall {wall:6.3f} s  cpu {cpu:6.3f} s  bandwidth "
                  f"{result.metrics['bandwidth'].value:.4f} rad/s  load "
                  f"{os.getloadavg()[0]:.2f}", flush=True)
    (w1, c1), (wn, cn) = ((statistics.median(t[0] for t in times[k]),
                           statistics.median(t[1] for t in times[k])) for k in times)
    print(f"median threads=1: wall {w1:.3f} s, cpu {c1:.3f} s; threads=None: wall {wn:.3f} s, "
          f"cpu {cn:.3f} s; ratio (None/1): wall {wn / w1:.2f}, cpu {cn / c1:.2f}")


if __name__ == "__main__":
    main()
