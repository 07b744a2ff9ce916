#!/usr/bin/env python
"""Measured, not built: the scalar search (feedtune.tuner.scalar) on the batch's
one-tunable specs, whose |e| objective gives the NLP an epigraph slack (kinds 0 and 1 of
``batch_throughput.py``: K free, T fixed or none, a damping constraint).

The tuner declines the scalar search for them (``scalar.applies``: one NLP variable only),
and tests pin that (tests/unit/test_scalar_search.py's ``epigraph`` case,
tests/reference/test_tian.py: Koren's reference-pulse example solved by IPOPT,
tests/cli/test_result_honesty.py: its sampled-data example's 8 starts). This script
lets it apply in this process (any problem with one tunable and no exchange point; the
objective it minimises is the NLP check's, |e| itself) with ``--grid`` extra points
spread over the box in ln K besides the starts and the box's ends, and compares with IPOPT
on the same specs, alternately, ``--rounds`` times:

* CPU ms a spec of the whole ``feedtune.batch.job.solve`` and of its starts (``_run_start``
  and the search's grid);
* |Δ ln K| between the two tuned gains, against IPOPT's own spread (the largest |Δ ln K|
  between two of a spec's IPOPT starts that solved feasibly);
* |Δ objective| in BLUs of each spec;
* how many results differ in status, number of starts reported or uniqueness.

    .venv/bin/python benchmarks/batch_epigraph_search.py --specs 90 --grid 17
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
from feedtune.expr import Magnitude  # noqa: E402
from feedtune.tuner import nlp, scalar  # noqa: E402
from feedtune.tuner.calls import numeric  # noqa: E402


def _wide(problem) -> bool:
    """One free tunable and no exchange point: epigraph slacks allowed."""
    return bool(problem.has_nlp and problem.n_z == 1 and not problem.exchange_groups)


REASONS = {"start infeasible": 0, "no sign change": 0}  # why starts were left to IPOPT


def _one_magnitude(problem) -> bool:
    """One tunable, no exchange point, the objective one |e| minimised: a root of e."""
    ev = problem.evaluator
    return bool(problem.has_nlp and problem.n_z == 1 and not problem.exchange_groups
                and ev.term_magnitude == [True] and len(ev.weights) == 1 and ev.weights[0] > 0
                and ev.term_scans == [None])


def _root_start(problem, z0: np.ndarray, grid_size: int, fallback):
    """One start by root-finding (``--method roots``): on a grid over the box (starts, ends
    and ``grid_size`` points in ln K), the feasible run of grid points around the start's,
    the sign change of the signed e nearest the start, Brent's root finder to 1e-14 in ln K
    (IPOPT's own spread is larger). Anything else (no sign change there: the optimum is on
    a bound or a feasibility boundary) is left to ``fallback`` (IPOPT); returns (run, by
    roots)."""
    from scipy import optimize

    p = problem.param_values
    check = numeric(problem.evaluator.function)

    def signed(z):
        return float(check.named(z=np.array([z]), p=p[:problem.evaluator.n_params])["terms"][0, 0])

    def feasible(z):
        seen = problem._seen_at(np.array([z]))
        settling = np.asarray(problem.settling(np.array([z]), p), dtype=float).reshape(-1, 1)
        bounds = np.array([np.nan if v is None else v for v in seen.bounds]).reshape(-1, 1)
        return bool(scalar.violation(bounds, seen.stability.reshape(-1, 1), settling,
                                     problem.bounds)[0] <= 0 and seen.objective is not None)

    grid = getattr(problem, "_root_grid", None)
    if grid is None:
        lower, upper = float(problem.lbw[0]), float(problem.ubw[0])
        points = np.unique(np.concatenate([[lower, upper], np.asarray(problem.starts)[:, 0],
                                           np.linspace(lower, upper, grid_size)]))
        grid = problem._root_grid = (points, np.array([signed(z) for z in points]),
                                     np.array([feasible(z) for z in points]))
    points, values, ok = grid
    i = int(np.argmin(np.abs(points - z0[0])))
    if not ok[i]:
        REASONS["start infeasible"] += 1
        return fallback(), False
    left, right = i, i
    while left > 0 and ok[left - 1]:
        left -= 1
    while right < len(points) - 1 and ok[right + 1]:
        right += 1
    brackets = [j for j in range(left, right) if values[j] == 0 or values[j] * values[j + 1] < 0]
    if not brackets:
        REASONS["no sign change"] += 1
        return fallback(), False
    j = min(brackets, key=lambda j: abs(0.5 * (points[j] + points[j + 1]) - z0[0]))
    root, info = optimize.brentq(signed, points[j], points[j + 1], xtol=1e-14,
                                 full_output=True)
    z = np.array([root])
    objective, bounds, conditions, matrices = problem._evaluate(z)
    is_feasible, _ = problem._feasible(bounds, conditions, matrices)
    return nlp._Run("optimal", "Solve_Succeeded", objective, info.iterations, 0, is_feasible,
                    z, bounds, conditions, None), True


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--specs", type=int, default=90, help="first specs (kinds 0, 1 kept)")
    parser.add_argument("--grid", type=int, default=17, help="extra grid points in ln K")
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--method", choices=["scalar", "roots"], default="scalar",
                        help="the scalar search as it is (Brent on |e|), or root-finding of e")
    args = parser.parse_args(argv)
    specs = generate(max(args.specs, 300))
    for spec in one_spec_per_structure(specs):
        job.solve(json.dumps(spec).encode())
    chosen = [s for i, s in enumerate(specs[:args.specs]) if i % 3 != 2]
    data = [json.dumps(s).encode() for s in chosen]

    mode = "ipopt"
    starts_cpu = {"ipopt": 0.0, "scalar": 0.0}
    ends: list = []  # the z of each start of the spec being solved
    run_start, post_init = nlp.Problem._run_start, scalar.ScalarSearch.__post_init__

    by_roots = [0, 0]  # starts by roots, starts left to IPOPT

    def timed_run(self, z0, started):
        clock = time.process_time()
        try:
            if mode == "scalar" and args.method == "roots" and _one_magnitude(self):
                run, rooted = _root_start(self, z0, args.grid,
                                          lambda: run_start(self, z0, started))
                by_roots[not rooted] += 1
            else:
                run = run_start(self, z0, started)
            if run.status in ("optimal", "acceptable") and run.feasible:
                ends.append(float(run.z[0]))
            return run
        finally:
            starts_cpu[mode] += time.process_time() - clock

    def timed_grid(self):
        clock = time.process_time()
        self.starts = np.concatenate([self.starts, np.linspace(self.lower, self.upper,
                                                               args.grid)])
        try:
            return post_init(self)
        finally:
            starts_cpu[mode] += time.process_time() - clock

    nlp.Problem._run_start = timed_run
    scalar.ScalarSearch.__post_init__ = timed_grid
    applies = scalar.applies  # nlp holds it as scalar_search_applies
    total = {"ipopt": 0.0, "scalar": 0.0}
    results: dict[str, list] = {}
    spreads = []
    load = os.getloadavg()[0]
    for _ in range(args.rounds):
        for mode in total:
            wide = mode == "scalar" and args.method == "scalar"
            nlp.scalar_search_applies = scalar.applies = _wide if wide else applies
            out, spread = [], []
            clock = time.process_time()
            for d in data:
                ends.clear()
                out.append(json.loads(job.solve(d).result))
                spread.append(max(ends) - min(ends) if len(ends) > 1 else 0.0)
            total[mode] += time.process_time() - clock
            results[mode] = out
            if mode == "ipopt":
                spreads = spread
    nlp.scalar_search_applies = scalar.applies = applies
    n = len(data) * args.rounds
    print(f"{len(data)} specs of kinds 0 and 1 (first {args.specs}), {args.rounds} rounds, "
          f"grid +{args.grid}; load average {load:.2f} before, {os.getloadavg()[0]:.2f} after")
    for m in total:
        print(f"  {m:7s} {total[m] / n * 1e3:6.2f} ms a spec, starts {starts_cpu[m] / n * 1e3:6.2f}")
    dk, dobj, differ = [], [], 0
    for a, b, spec in zip(results["ipopt"], results["scalar"], chosen):
        ka, kb = (r["tuned"]["position_gain"]["value"] for r in (a, b))
        dk.append(abs(math.log(kb) - math.log(ka)))
        dobj.append(abs((b["objective"] or 0.0) - (a["objective"] or 0.0)) / spec["plant"]["blu"])
        differ += (a["status"] != b["status"]
                   or len(a["solver"]["starts"]) != len(b["solver"]["starts"])
                   or a["optimum"]["unique"] != b["optimum"]["unique"])
    dk, dobj, spreads = np.array(dk), np.array(dobj), np.array(spreads)
    methods = {m: sum(r["solver"]["method"] == m for r in results["scalar"])
               for m in ("ipopt", "brent")}
    print(f"  solved by the search: {methods}" if args.method == "scalar" else
          f"  starts by roots {by_roots[0] // args.rounds}, left to IPOPT {by_roots[1] // args.rounds} "
          f"({', '.join(f'{k} {v // args.rounds}' for k, v in REASONS.items())})")
    print(f"  |Δ ln K| search vs IPOPT: median {np.median(dk):.1e}, 90 % {np.quantile(dk, .9):.1e}, "
          f"max {dk.max():.1e}")
    print(f"  IPOPT's own spread of ln K over a spec's starts: median {np.median(spreads):.1e}, "
          f"90 % {np.quantile(spreads, .9):.1e}, max {spreads.max():.1e}")
    print(f"  |Δ objective| / BLU: median {np.median(dobj):.1e}, max {dobj.max():.1e}")
    print(f"  status, starts reported or uniqueness differ: {differ} of {len(data)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
