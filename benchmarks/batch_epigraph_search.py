#!/usr/bin/env python
"""IPOPT against the root search (feedtune.tuner.roots) on the batch's one-tunable specs,
whose |e| objective gives the NLP an epigraph slack (kinds 0 and 1 of
``batch_throughput.py``: K free, T fixed or none, a damping constraint).

The tuner solves each start of these specs by a root of the signed e (or a constraint's
crossing where |e| is least), IPOPT only for the starts the search declines. This script
runs the same specs with the root search turned off in this process (``ipopt``: the
tuner as on main) and on (``root``), alternately, ``--rounds`` times, and prints

* CPU ms a spec of the whole ``feedtune.batch.job.solve`` and of its starts
  (``Problem._run_start``, the root search's grid in ``Problem.__init__`` included);
* how many starts the root search solved, and which it left to IPOPT;
* |Δ ln K| between the two tuned gains, against IPOPT's own spread (the largest
  |Δ ln K| between two of a spec's IPOPT starts that solved feasibly), and per start the
  |Δ ln K| of the two end points and |Δ objective| in BLUs;
* how many results differ in status, starts reported, uniqueness, or which starts reached
  the best objective, and how many starts differ in status or feasibility.

    .venv/bin/python benchmarks/batch_epigraph_search.py --specs 90 --rounds 2
"""

from __future__ import annotations

import os

for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(1, str(Path(__file__).resolve().parent))

from batch_throughput import generate, one_spec_per_structure  # noqa: E402

import feedtune.batch.job as job  # noqa: E402
from feedtune.tuner import nlp, roots  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--specs", type=int, default=90, help="first specs (kinds 0, 1 kept)")
    parser.add_argument("--rounds", type=int, default=2)
    args = parser.parse_args(argv)
    specs = generate(max(args.specs, 300))
    for spec in one_spec_per_structure(specs):
        job.solve(json.dumps(spec).encode())
    chosen = [s for i, s in enumerate(specs[:args.specs]) if i % 3 != 2]
    data = [json.dumps(s).encode() for s in chosen]

    mode = "ipopt"
    starts_cpu = {"ipopt": 0.0, "root": 0.0}
    ends: list = []  # (z, status, feasible, method) of each start of the spec being solved
    run_start, for_problem = nlp.Problem._run_start, roots.RootSearch.for_problem

    def timed_run(self, z0, started):
        clock = time.process_time()
        try:
            run = run_start(self, z0, started)
            ends.append((float(run.z[0]), run.status, run.feasible, run.method))
            return run
        finally:
            starts_cpu[mode] += time.process_time() - clock

    def timed_grid(problem):
        clock = time.process_time()
        try:
            return for_problem(problem)
        finally:
            starts_cpu[mode] += time.process_time() - clock

    nlp.Problem._run_start = timed_run
    roots.RootSearch.for_problem = staticmethod(timed_grid)
    applies = roots.applies
    total = {"ipopt": 0.0, "root": 0.0}
    results: dict[str, list] = {}
    per_start: dict[str, list] = {}
    load = os.getloadavg()[0]
    for _ in range(args.rounds):
        for mode in total:
            nlp.root_search_applies = applies if mode == "root" else (lambda problem: False)
            out, seen = [], []
            clock = time.process_time()
            for d in data:
                ends.clear()
                out.append(json.loads(job.solve(d).result))
                seen.append(list(ends))
            total[mode] += time.process_time() - clock
            results[mode], per_start[mode] = out, seen
    nlp.root_search_applies = applies
    n = len(data) * args.rounds
    print(f"{len(data)} specs of kinds 0 and 1 (first {args.specs}), {args.rounds} rounds; "
          f"load average {load:.2f} before, {os.getloadavg()[0]:.2f} after")
    for m in total:
        print(f"  {m:6s} {total[m] / n * 1e3:6.2f} ms a spec, starts {starts_cpu[m] / n * 1e3:6.2f}")
    dk, dobj, spreads, start_dk, start_dobj = [], [], [], [], []
    differ = starts_differ = by_root = by_ipopt = 0
    for a, b, sa, sb, spec in zip(results["ipopt"], results["root"], per_start["ipopt"],
                                  per_start["root"], chosen):
        blu = spec["plant"]["blu"]
        ka, kb = (r["tuned"]["position_gain"]["value"] for r in (a, b))
        dk.append(abs(math.log(kb) - math.log(ka)))
        dobj.append(abs((b["objective"] or 0.0) - (a["objective"] or 0.0)) / blu)
        solved = [z for z, status, feasible, _ in sa if status == "optimal" and feasible]
        spreads.append(max(solved) - min(solved) if len(solved) > 1 else 0.0)
        differ += (a["status"] != b["status"]
                   or len(a["solver"]["starts"]) != len(b["solver"]["starts"])
                   or a["optimum"]["unique"] != b["optimum"]["unique"]
                   or a["optimum"]["starts"] != b["optimum"]["starts"])
        for x, y, ra, rb in zip(sa, sb, a["solver"]["starts"], b["solver"]["starts"]):
            by_root += y[3] == "root"
            by_ipopt += y[3] != "root"
            starts_differ += (x[1], x[2]) != (y[1], y[2])
            start_dk.append(abs(x[0] - y[0]))
            start_dobj.append(abs((ra["objective"] or 0.0) - (rb["objective"] or 0.0)) / blu)
    dk, dobj, spreads = np.array(dk), np.array(dobj), np.array(spreads)
    start_dk, start_dobj = np.array(start_dk), np.array(start_dobj)

    def q(x):
        return f"median {np.median(x):.1e}, 90 % {np.quantile(x, .9):.1e}, max {x.max():.1e}"

    print(f"  starts (last round) by the root search {by_root}, left to IPOPT {by_ipopt}")
    print(f"  tuned |Δ ln K| root vs IPOPT: {q(dk)}")
    print(f"  IPOPT's own spread of ln K over a spec's starts: {q(spreads)}")
    print(f"  tuned |Δ objective| / BLU: {q(dobj)}")
    print(f"  per start: |Δ ln K| {q(start_dk)}; |Δ objective| / BLU {q(start_dobj)}")
    print(f"  results whose status, starts, uniqueness or best starts differ: {differ} of "
          f"{len(data)}; starts whose status or feasibility differ: {starts_differ}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
