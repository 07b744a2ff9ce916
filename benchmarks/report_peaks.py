"""A tuned design's peak refinement (``frequency._peak_of_numbers``), this checkout's
against a git revision's ``feedtune/loops/frequency.py``, side by side in one process
(issue 15, branch h-bev3).

Runs ``--specs`` specs of ``benchmarks/batch_throughput.py``'s generated set through
``feedtune.batch.job.solve`` after one spec of each kind, capturing every replayed peak's
inputs (f, f′, f″ of the loop's twin with its numbers bound, the ln ω grid, the half
step); then refines each captured peak with both modules, each with its own maps of the
same Functions (the baseline's folds and jet built by its own code), alternating per
round, and compares their (top, ln ω) on every peak: the tops must agree to 1e-9 of their
value (h-bev6: 20 golden steps instead of 48 moved them by ≤ 3e-12); it prints how many are
bit-equal and the largest difference.

    .venv/bin/python benchmarks/report_peaks.py [--baseline main] [--specs 40] [--rounds 5]
"""

from __future__ import annotations

import os

for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402

from baseline import baseline_module  # noqa: E402
from batch_throughput import generate, one_spec_per_structure  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", default="main", help="git revision of the old module")
    parser.add_argument("--specs", type=int, default=40, help="specs whose peaks are captured")
    parser.add_argument("--rounds", type=int, default=5, help="alternating rounds")
    args = parser.parse_args()
    import numpy as np

    import feedtune.batch.job as job
    import feedtune.loops.frequency as new

    old = baseline_module(args.baseline, "feedtune/loops/frequency.py", "baseline_frequency")
    specs = generate(max(args.specs, 300))
    for spec in one_spec_per_structure(specs):
        job.solve(json.dumps(spec).encode())
    captured = []
    refine = new._peak_of_numbers

    def capture(f, slope, curvature, grid, h):
        captured.append((f, slope, curvature, np.array(grid), h))
        return refine(f, slope, curvature, grid, h)

    new._peak_of_numbers = capture
    try:
        for spec in specs[:args.specs]:
            job.solve(json.dumps(spec).encode())
    finally:
        new._peak_of_numbers = refine
    maps: dict = {}  # the baseline's own Mapped of each Function (its derived ones its own)
    baseline = [([maps.setdefault(m.fn, old.Mapped(m.fn, expand=False)).bound(*m.fixed)
                  for m in (f, s, c)], grid, h) for f, s, c, grid, h in captured]
    for _ in range(2):  # each side builds its folds and jet (at a Function's second request)
        pairs = [(refine(f, s, c, grid, h), old._peak_of_numbers(*rows, grid, h))
                 for (f, s, c, grid, h), (rows, _, _) in zip(captured, baseline)]
    equal = sum(new_top == old_top for new_top, old_top in pairs)
    moved = max(abs(n[0] - o[0]) / abs(o[0]) for n, o in pairs)
    assert moved <= 1e-9, moved
    cpu = {"old": 0.0, "new": 0.0}
    load = os.getloadavg()[0]
    for _ in range(args.rounds):
        started = time.process_time()
        for rows, grid, h in baseline:
            old._peak_of_numbers(*rows, grid, h)
        cpu["old"] += time.process_time() - started
        started = time.process_time()
        for f, s, c, grid, h in captured:
            refine(f, s, c, grid, h)
        cpu["new"] += time.process_time() - started
    count = len(captured) * args.rounds
    print(f"{len(captured)} peaks of {args.specs} specs × {args.rounds} rounds, (top, ln ω) "
          f"bit-equal on {equal}, tops within {moved:.1e} relative; CPU ms a peak: baseline {cpu['old'] / count * 1e3:.3f}, "
          f"new {cpu['new'] / count * 1e3:.3f}, new/baseline {cpu['new'] / cpu['old']:.2f}; "
          f"load {load:.1f} → {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
