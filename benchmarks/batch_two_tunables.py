#!/usr/bin/env python
"""The batch's two-tunable specs (K and T free, |e| minimised): each start's method, IPOPT's
iterations, evaluations and CPU, the root starts' CPU, and where the starts end.

Runs ``feedtune.batch.job.solve`` on the specs of kind 2 among the first ``--specs`` of
``benchmarks/batch_throughput.py``'s generated set (after one untimed solve of each
structure), in this process with one BLAS thread, timing every IPOPT call (the nlpsol's
numeric call), every IPOPT start (``Problem._solve_from``: restoration, the extra
variables' start, IPOPT) and every root start (``Problem._root_along``, where the tree has
it) in CPU time. IPOPT's own counters (``n_call_nlp_*``, ``t_proc_nlp_*``) are read from
the solver's statistics after each call (CasADi accumulates them per solver: differences).

    .venv/bin/python benchmarks/batch_two_tunables.py --specs 300
    FEEDTUNE_BENCH_TREE=/tmp/base .venv/bin/python benchmarks/batch_two_tunables.py   # another tree
"""

from __future__ import annotations

import os

for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from collections import Counter  # noqa: E402
from pathlib import Path  # noqa: E402

TREE = Path(os.environ.get("FEEDTUNE_BENCH_TREE") or Path(__file__).resolve().parents[1])
sys.path.insert(0, str(TREE))
sys.path.insert(1, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402

import feedtune  # noqa: E402, F401  (from TREE, before batch_throughput adds its own checkout)
from batch_throughput import generate, one_spec_per_structure  # noqa: E402

import feedtune.batch.job as job  # noqa: E402
import feedtune.tuner.calls as calls  # noqa: E402
import feedtune.tuner.nlp as nlp  # noqa: E402

COUNTERS = ("n_call_nlp_f", "n_call_nlp_g", "n_call_nlp_grad_f", "n_call_nlp_jac_g",
            "n_call_nlp_hess_l")
TIMERS = ("t_proc_nlp_f", "t_proc_nlp_g", "t_proc_nlp_grad_f", "t_proc_nlp_jac_g",
          "t_proc_nlp_hess_l")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--specs", type=int, default=300)
    args = parser.parse_args(argv)
    specs = generate(max(args.specs, 300))
    for spec in one_spec_per_structure(specs):
        job.solve(json.dumps(spec).encode())

    ipopt, starts, roots, before = [], [], [], {}
    named = calls.NumericCall.named

    def timed_named(self, **inputs):  # the nlpsol's call: CPU and its statistics' differences
        started = time.process_time()
        out = named(self, **inputs)
        if self.name == "feedtune":
            stats = self.stats()
            last = before.get(id(self), {})
            before[id(self)] = stats
            ipopt.append({"cpu": time.process_time() - started,
                          "iterations": stats.get("iter_count", 0),
                          "evaluations": [stats.get(k, 0) - last.get(k, 0) for k in COUNTERS],
                          "functions": sum(stats.get(k, 0) - last.get(k, 0) for k in TIMERS)})
        return out

    calls.NumericCall.named = timed_named

    def timer(owner, name, into):
        original = getattr(owner, name)

        def timed(*a, **k):
            started = time.process_time()
            out = original(*a, **k)
            into.append((time.process_time() - started, out))
            return out

        setattr(owner, name, timed)

    timer(nlp.Problem, "_solve_from", starts)
    if hasattr(nlp.Problem, "_root_along"):  # this branch's root starts (h-bipo)
        timer(nlp.Problem, "_root_along", roots)

    chosen = [s for i, s in enumerate(specs[:args.specs]) if i % 3 == 2]
    methods, reached, load = Counter(), Counter(), os.getloadavg()[0]
    started = time.process_time()
    for spec in chosen:
        result = json.loads(job.solve(json.dumps(spec).encode()).result)
        runs = result["solver"]["starts"]
        methods.update(s["method"] for s in runs)
        reached[tuple(s["objective"] is not None and s["objective"] <= 1e-9 for s in runs)] += 1
    cpu = time.process_time() - started
    n = len(chosen)
    print(f"{n} two-tunable specs, feedtune from {TREE}: {cpu / n * 1e3:.1f} ms of CPU a spec "
          f"(timers included); load {load:.2f} before, {os.getloadavg()[0]:.2f} after")
    print(f"starts by method: {dict(methods)}")
    print("starts that reached |e| ≤ 1e-9 m, per spec: "
          + ", ".join(f"{''.join('0' if r else '+' for r in k)} {v}"
                      for k, v in reached.most_common()))
    if ipopt:
        its = np.array([c["iterations"] for c in ipopt])
        evals = np.array([c["evaluations"] for c in ipopt]).mean(axis=0)
        print(f"IPOPT calls: {len(ipopt)} ({len(ipopt) / n:.2f} a spec), "
              f"{np.mean([c['cpu'] for c in ipopt]) * 1e3:.2f} ms of CPU a call, of which the "
              f"NLP's Functions {np.mean([c['functions'] for c in ipopt]) * 1e3:.2f}; "
              f"iterations mean {its.mean():.1f}, median {np.median(its):.0f}, "
              f"{its.min()}–{its.max()}; evaluations a call (f, g, ∇f, ∂g, ∇²L): "
              + ", ".join(f"{e:.1f}" for e in evals))
    print(f"IPOPT starts (restoration, extra variables' start, IPOPT): {len(starts)}, "
          f"{sum(t for t, _ in starts) / n * 1e3:.2f} ms a spec")
    if roots:
        found = [t for t, (z, _) in roots if z is not None]
        declined = [t for t, (z, _) in roots if z is None]
        print(f"root starts: {len(found)} found, {np.mean(found or [0]) * 1e3:.2f} ms each; "
              f"{len(declined)} declined (then IPOPT), {np.mean(declined or [0]) * 1e3:.2f} ms "
              f"each; {sum(t for t, _ in roots) / n * 1e3:.2f} ms a spec")
    return 0


if __name__ == "__main__":
    sys.exit(main())
