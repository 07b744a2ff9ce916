#!/usr/bin/env python
"""Koren's sampled-data IAE (issue 15): per-solve and per-tuning times, IPOPT against the
scalar search and against Brent on a numpy IAE, and one feedtune tree against another,
side by side in one run.

Cases (software_servo, sampled data, τ = 20 ms, K ∈ [1, 200] 1/s free):

* ``case3``: T = 1/64 s, min IAE after a unit step, time absolute (benchmarks/
  koren_vs_scipy.py case 3; the issue's 28 ms per solve, 0.66 s per tuning);
* ``min-iae-radius``: ``examples/koren-1979-min-iae-radius.json`` (T = 10 ms, IAE in
  natural time, 4 starts).

For each tree (``--tree LABEL=PATH``, a checkout whose ``feedtune`` package is used; by
default only this one) a worker process is started per round, the trees alternating
(ABAB…, then BABA… the next round), so load from other processes hits both alike. Each
worker imports feedtune, tunes every case once untimed (IPOPT loaded, first calls paid),
then ``--repeats`` times with the solver cache cleared (every build paid, as on a first
tuning) and reports the best:

* ``tuning``: ``tune(parse_spec(spec))`` wall time after imports, validation included;
* ``build``, ``nlpsol`` (the part of build spent creating IPOPT's solver: SX expansion and
  derivatives), ``solve`` (all starts), ``solve1`` (the first start, the issue's "per
  solve"), ``evaluation`` (the tuned design evaluated on numbers), ``rest`` (validation,
  result); ``starts``, ``iterations`` (summed), ``K`` and the objective;
* per mode: ``ipopt`` (the tuner as the tree has it) and, when the tree has
  ``feedtune.tuner.scalar``, ``scalar`` — the scalar search hooked into the tuner. Until
  the tuner calls it itself, the worker applies the hook by patching
  (:func:`apply_scalar_hook`, the lines the tuner needs, see feedtune/tuner/scalar.py);
* ``brent``: scipy's bounded Brent on ln K on the exact numpy IAE of koren_vs_scipy.py
  (case3 only; xatol 1e-8, as there), best of the repeats, in the same worker.

The table shows each tree's best over the rounds, ratios between the trees (first over
others) and against Brent. Timings are wall clock on a shared machine: the load average is
printed; compare ratios, not absolute values. Run:

    .venv/bin/python benchmarks/koren_iae_speed.py
    .venv/bin/python benchmarks/koren_iae_speed.py --tree old=/path/to/old/checkout --tree new=.
"""

from __future__ import annotations

import argparse
import inspect
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
PLANT = {"type": "software_servo", "technique": "sampled_data", "time_constant": 0.02,
         "blu": 5e-6, "max_velocity": 0.04}
CASES = {
    "case3": {"name": "bench-3", "plant": PLANT,
              "tunables": {"position_gain": {"min": 1, "max": 200},
                           "sampling_period": {"value": 1 / 64}},
              "objective": [{"metric": "iae", "time": "absolute"}]},
    "min-iae-radius": json.loads((HERE.parent / "examples" / "koren-1979-min-iae-radius.json")
                                 .read_text()),
}
#: ``--free-period``: IAE with K and T free, T down to 1 ms (the horizon's sample count is
#: set by T_min); tuned once per worker, IPOPT only (two free tunables)
FREE_PERIOD = {"name": "iae-free-period", "plant": PLANT,
               "tunables": {"position_gain": {"min": 1, "max": 200},
                            "sampling_period": {"min": 0.001, "max": 0.5}},
               "objective": [{"metric": "iae"}], "solver": {"multistart": 4}}
TIMES = ("tuning", "build", "nlpsol", "solve", "solve1", "evaluation", "rest")


def apply_scalar_hook() -> str:
    """Route one-free-tunable problems to :mod:`feedtune.tuner.scalar`, as the tuner's hook
    does: no IPOPT solver built, the grid minima as starts, each start refined by the
    scalar search, its flatness test instead of IPOPT's Hessian. Returns how the hook is
    present: ``tuner`` (the tuner calls the search itself), ``patched`` or ``absent``."""
    try:
        from feedtune.tuner import nlp, scalar
    except ImportError:
        return "absent"
    if "scalar" in inspect.getsource(nlp):
        return "tuner"
    import numpy as np

    build = nlp._cached_build

    def cached_build(functions, probe, options, expand, has_nlp):
        one = (functions["nlp"].size1_in(0) == 1
               and functions["exchange_check"].size1_out(0) == 0)
        return build(functions, probe, options, expand, has_nlp and not one)

    init, solve_from, solve = nlp.Problem.__init__, nlp.Problem._solve_from, nlp.Problem.solve

    def patched_init(self, *args, **kwargs):
        init(self, *args, **kwargs)
        self.scalar = (scalar.ScalarSearch.for_problem(self, self.check, self.settling)
                       if self._nlpsol is None else None)
        if self.scalar is not None:
            self.starts = self.scalar.start_points()

    def patched_solve_from(self, start, started):
        if self.scalar is not None:
            return self.scalar.solve_from(start, started)
        return solve_from(self, start, started)

    def patched_solve(self, progress=None):
        outcome = solve(self, progress)
        if self.scalar is not None and outcome.success:
            name = self.variables[0].name
            outcome.flat_tunables = self.scalar.flat_tunables(
                np.log([outcome.values[name]]), name)
        return outcome

    nlp._cached_build = cached_build
    nlp.Problem.__init__ = patched_init
    nlp.Problem._solve_from = patched_solve_from
    nlp.Problem.solve = patched_solve
    return "patched"


def remove_scalar_hook(saved) -> None:
    from feedtune.tuner import nlp

    nlp._cached_build, nlp.Problem.__init__, nlp.Problem._solve_from, nlp.Problem.solve = saved


def _tune_once(spec: dict, nlpsol_time: list) -> dict:
    from feedtune.problem import tune
    from feedtune.spec import parse_spec
    from feedtune.tuner import nlp

    nlp.clear_solver_cache()
    nlpsol_time.clear()
    started = time.perf_counter()
    result = tune(parse_spec(spec))
    wall = time.perf_counter() - started
    s = result.solver
    return {"tuning": wall, "build": s.build_time, "nlpsol": sum(nlpsol_time),
            "solve": s.solve_time, "solve1": s.starts[0].solve_time,
            "evaluation": s.evaluation_time,
            "rest": wall - s.build_time - s.solve_time - s.evaluation_time,
            "starts": len(s.starts), "iterations": sum(st.iterations for st in s.starts),
            "K": result.tuned["position_gain"].value, "objective": result.objective,
            "success": result.success, "validation_ok": (result.validation or {}).get("ok"),
            "unique": result.optimum.unique if result.optimum else None}


def _timer(owner, name: str, into: dict, key: str):
    """Wrap ``owner.name`` so that its calls add their wall time to ``into[key]``; returns
    the original, for :func:`_restore`."""
    original = getattr(owner, name)

    def timed(*args, **kwargs):
        started = time.perf_counter()
        try:
            return original(*args, **kwargs)
        finally:
            into[key] = into.get(key, 0.0) + time.perf_counter() - started

    setattr(owner, name, timed)
    return owner, name, original


def profile(spec: dict, scalar_mode: bool) -> dict:
    """Where one tuning's time goes [s], the solver cache cleared (module docstring)."""
    import feedtune.problem as problem_module
    from feedtune.problem import tune
    from feedtune.spec import parse_spec
    from feedtune.tuner import nlp

    parts: dict[str, float] = {}
    stats: list[dict] = []
    wrapped = [_timer(nlp, "_nlpsol", parts, "nlpsol (SX expansion, derivatives)"),
               _timer(problem_module, "_validation", parts, "validation"),
               _timer(nlp.Problem, "_evaluate_numeric", parts, "evaluation on numbers")]
    if scalar_mode:
        from feedtune.tuner import scalar

        wrapped += [_timer(scalar.ScalarSearch, "__post_init__", parts, "grid (starts, box ends)"),
                    _timer(scalar.ScalarSearch, "solve_from", parts, "Brent refinements"),
                    _timer(scalar.ScalarSearch, "flat_tunables", parts, "flatness")]
    else:
        solve_from = nlp.Problem._solve_from

        def counted(self, *args):
            out = solve_from(self, *args)
            stats.append(self._nlpsol.stats())
            return out

        nlp.Problem._solve_from = counted
        wrapped.append((nlp.Problem, "_solve_from", solve_from))
    nlp.clear_solver_cache()
    started = time.perf_counter()
    result = tune(parse_spec(spec))
    parts["tuning"] = time.perf_counter() - started
    for owner, name, original in wrapped:
        setattr(owner, name, original)
    s = result.solver
    parts["build"] = s.build_time
    parts["solve (all starts)"] = s.solve_time
    for key, label in (("nlp_f", "IPOPT objective"), ("nlp_grad_f", "IPOPT gradient"),
                       ("nlp_hess_l", "IPOPT Hessian")):
        if stats:
            parts[f"{label} ({sum(st.get('n_call_' + key, 0) for st in stats)} calls)"] = sum(
                st.get("t_wall_" + key, 0.0) for st in stats)
    parts["starts"] = len(s.starts)
    parts["iterations"] = sum(st.iterations for st in s.starts)
    return parts


def _best(runs: list[dict]) -> dict:
    best = min(runs, key=lambda r: r["tuning"])
    return {**best, **{key: min(r[key] for r in runs) for key in TIMES}}


def brent_case3(repeats: int) -> dict:
    """scipy bounded Brent on ln K, exact numpy IAE (koren_vs_scipy.py), best time."""
    sys.path.insert(0, str(HERE))
    import koren_vs_scipy as kvs
    from scipy import optimize

    best = math.inf
    for _ in range(repeats):
        started = time.perf_counter()
        res = optimize.minimize_scalar(lambda z: kvs.iae_sampled(math.exp(z), kvs.T_FIXED),
                                       bounds=(0.0, math.log(200.0)), method="bounded",
                                       options={"xatol": 1e-8, "maxiter": 500})
        best = min(best, time.perf_counter() - started)
    return {"solve1": best, "tuning": best, "K": math.exp(res.x),
            "objective": kvs.iae_sampled(math.exp(res.x), kvs.T_FIXED), "evaluations": res.nfev}


def worker(repeats: int, profiles: bool = False, free_period: bool = False) -> dict:
    """Every case and mode in this process (see module docstring); a JSON-able dict."""
    from feedtune.problem import tune
    from feedtune.spec import parse_spec
    from feedtune.tuner import nlp

    nlpsol_time: list[float] = []
    nlpsol = nlp._nlpsol

    def timed_nlpsol(*args):
        started = time.perf_counter()
        solver = nlpsol(*args)
        nlpsol_time.append(time.perf_counter() - started)
        return solver

    nlp._nlpsol = timed_nlpsol
    out = {"load": os.getloadavg()[0]}
    for case, spec in CASES.items():
        tune(parse_spec(spec))  # untimed: IPOPT loaded, first calls paid
        out[f"{case}/ipopt"] = _best([_tune_once(spec, nlpsol_time) for _ in range(repeats)])
    saved = (nlp._cached_build, nlp.Problem.__init__, nlp.Problem._solve_from, nlp.Problem.solve)
    hook = apply_scalar_hook()
    out["hook"] = hook
    if hook != "absent":
        for case, spec in CASES.items():
            tune(parse_spec(spec))
            out[f"{case}/scalar"] = _best([_tune_once(spec, nlpsol_time) for _ in range(repeats)])
    if hook == "patched":
        remove_scalar_hook(saved)
    out["case3/brent"] = brent_case3(repeats)
    if free_period:
        out["free-period/ipopt"] = _tune_once(FREE_PERIOD, nlpsol_time)
    if profiles:
        out["profile"] = {}
        for case, spec in CASES.items():
            out["profile"][f"{case}/ipopt"] = profile(spec, False)
            if hook == "patched":
                apply_scalar_hook()
            if hook != "absent":
                out["profile"][f"{case}/scalar"] = profile(spec, True)
            if hook == "patched":
                remove_scalar_hook(saved)
    return out


def _run_worker(path: str, repeats: int, profiles: bool, free_period: bool) -> dict:
    env = {**os.environ, "PYTHONPATH": path, "OPENBLAS_NUM_THREADS": "1",
           "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    proc = subprocess.run([sys.executable, __file__, "--worker", "--repeats", str(repeats)]
                          + (["--profile"] if profiles else [])
                          + (["--free-period"] if free_period else []),
                          env=env, capture_output=True, text=True, cwd="/")
    if proc.returncode:
        raise RuntimeError(f"worker for {path} failed:\n{proc.stderr}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tree", action="append", default=[],
                        help="LABEL=PATH of a feedtune checkout (repeatable; default: this one)")
    parser.add_argument("--rounds", type=int, default=3, help="worker processes per tree")
    parser.add_argument("--repeats", type=int, default=5, help="tunings per case per worker")
    parser.add_argument("--profile", action="store_true",
                        help="also print where one tuning's time goes, per case and mode")
    parser.add_argument("--free-period", action="store_true",
                        help="also tune IAE with T free in [1 ms, 0.5 s] once per worker "
                             "(minutes on an old tree)")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.worker:
        print(json.dumps(worker(args.repeats, args.profile, args.free_period)))
        return 0
    trees = dict(t.split("=", 1) for t in args.tree) or {"this": str(HERE.parent)}
    trees = {label: str(Path(path).resolve()) for label, path in trees.items()}
    load_start = os.getloadavg()[0]
    runs: dict[str, list[dict]] = {label: [] for label in trees}
    for r in range(args.rounds):
        order = list(trees) if r % 2 == 0 else list(reversed(trees))
        for label in order:
            runs[label].append(_run_worker(trees[label], args.repeats,
                                           args.profile and r == args.rounds - 1,
                                           args.free_period and r == 0))
    print(f"Koren sampled-data IAE speed: {args.rounds} rounds x {args.repeats} tunings per "
          f"case, trees alternating; load average (1 min) {load_start:.2f} at start, "
          f"{os.getloadavg()[0]:.2f} at end, on {os.cpu_count()} CPUs")
    for label, path in trees.items():
        print(f"  {label}: {path} (scalar hook: {runs[label][0]['hook']})")
    print("times in ms, best over rounds; 'tuning' is tune() after imports, solver cache "
          "cleared; 'solve1' the first start")
    keys = [k for k in runs[next(iter(trees))][0] if "/" in k]
    for tree_runs in runs.values():
        keys += [k for k in tree_runs[0] if "/" in k and k not in keys]
    header = f"{'case/mode':<22} {'tree':<6} " + " ".join(f"{t:>10}" for t in TIMES) + \
        f" {'starts':>6} {'iter':>5} {'K 1/s':>14} {'objective':>17}  unique valid success"
    print(header)
    print("-" * len(header))
    best = {}
    for key in keys:
        for label, tree_runs in runs.items():
            rows = [run[key] for run in tree_runs if key in run]
            if not rows:
                continue
            merged = {**rows[0], **{t: min(r[t] for r in rows if t in r) for t in TIMES
                                   if t in rows[0]}}
            best[label, key] = merged
            cells = " ".join(f"{merged[t] * 1e3:10.2f}" if t in merged else f"{'-':>10}"
                             for t in TIMES)
            print(f"{key:<22} {label:<6} {cells} {merged.get('starts', '-'):>6} "
                  f"{merged.get('iterations', merged.get('evaluations', '-')):>5} "
                  f"{merged['K']:14.9f} "
                  f"{merged['objective'] if merged['objective'] is not None else '-':>17.12}  "
                  f"{str(merged.get('unique', '-')):>6} {str(merged.get('validation_ok', '-')):>5} "
                  f"{str(merged.get('success', '-')):>7}")
    print()
    print("ratios (time of the first over the second; > 1: the second is faster)")
    labels = list(trees)
    for key in keys:
        for label in labels:
            if (label, key) not in best or key.endswith("brent"):
                continue
            m = best[label, key]
            brent = best.get((label, "case3/brent"))
            if brent and key.startswith("case3/"):
                print(f"  {label} {key}: solve1 / Brent {m['solve1'] / brent['solve1']:.2f}, "
                      f"tuning / Brent {m['tuning'] / brent['tuning']:.1f}")
        for other in labels[1:]:
            if (labels[0], key) in best and (other, key) in best and not key.endswith("brent"):
                a, b = best[labels[0], key], best[other, key]
                print(f"  {key}: {labels[0]}/{other} tuning {a['tuning'] / b['tuning']:.2f}, "
                      f"solve1 {a['solve1'] / b['solve1']:.2f}, build "
                      f"{a['build'] / b['build']:.2f}")
    if args.profile:
        print()
        print("profile of one tuning per tree (last round), ms; parts overlap: build holds "
              "nlpsol and the grid, solve the IPOPT calls and Brent")
        for label, tree_runs in runs.items():
            for key, parts in tree_runs[-1].get("profile", {}).items():
                print(f"  {label} {key}: " + ", ".join(
                    f"{name} {value * 1e3:.1f}" if isinstance(value, float) else
                    f"{name} {value}" for name, value in parts.items()))
    for label in labels:
        for case in CASES:
            a, b = best.get((label, f"{case}/ipopt")), best.get((label, f"{case}/scalar"))
            if a and b:
                print(f"  {label} {case}: ipopt/scalar tuning {a['tuning'] / b['tuning']:.2f}, "
                      f"solve1 {a['solve1'] / b['solve1']:.2f}; dK/K "
                      f"{abs(b['K'] / a['K'] - 1):.1e}, objective rel. diff "
                      f"{(b['objective'] - a['objective']) / a['objective']:+.1e}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
