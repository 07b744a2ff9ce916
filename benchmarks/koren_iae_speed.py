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
worker imports feedtune, tunes every case and mode once untimed (IPOPT loaded, first calls
paid), then ``--repeats`` times with the solver cache cleared (every build paid, as on a
first tuning) and reports the best. Modes:

* ``ipopt``: the spec with ``"solver": {"ipopt_options": {"hessian_approximation":
  "exact"}}``. IPOPT options make every tree solve with IPOPT (a tree with the scalar
  search leaves it to IPOPT when the spec asks for IPOPT options; the old tree, 65fdeaa,
  always uses IPOPT, exact Hessian by default for these problems);
* ``scalar``: the spec as it is, in a tree whose tuner has ``feedtune.tuner.scalar`` and
  whose ``Settings`` has ``scalar_search``: the tuner itself routes a problem with one free
  tunable and nothing else to decide to the scalar search (no IPOPT solver built; the
  result's ``solver.method`` is ``brent``, shown in the ``method`` column);
* ``brent``: scipy's bounded Brent on ln K on the exact numpy IAE of koren_vs_scipy.py
  (case3 only; xatol 1e-8, as there), best of the repeats, in the same worker.

Nothing in the tuner is patched. Columns:

* ``tuning``: ``tune(parse_spec(spec))`` wall time after imports, validation included;
* ``build``, ``solve`` (all starts), ``solve1`` (the first start, the issue's "per solve"),
  ``evaluation`` (the tuned design evaluated on numbers): as the result reports them;
  ``rest`` = tuning − build − solve − evaluation (validation, the result);
* ``nlpsol``: wall time inside ``casadi.nlpsol`` (IPOPT's solver created: SX expansion and
  derivatives), taken by wrapping ``casadi.nlpsol`` in the worker, so it works on every
  tree; part of ``build`` (0 when no solver is built);
* ``starts``, ``iter`` (IPOPT or Brent iterations, summed), ``K``, the objective.

``--profile`` adds where one tuning's time goes (last round, one tuning per case and mode):
``casadi.nlpsol``, ``feedtune.problem._validation`` and ``Problem._evaluate_numeric``
timed by wrapping, IPOPT's own call counts and times from every solver call's ``stats()``
(the solver returned by ``casadi.nlpsol`` is wrapped to record them), and for the scalar
search the grid, the Brent refinements and the flatness test (``ScalarSearch``'s methods).

The table shows each tree's best over the rounds, ratios between the trees (first over
others) and against Brent. Timings are wall clock on a shared machine: the load average is
printed; compare ratios, not absolute values. Run:

    .venv/bin/python benchmarks/koren_iae_speed.py
    git archive 65fdeaa | tar -x -C /tmp/old     # the tuner before issue 15
    .venv/bin/python benchmarks/koren_iae_speed.py --tree new=. --tree old=/tmp/old --profile
"""

from __future__ import annotations

import argparse
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
#: the spec's solver options of mode ``ipopt``: IPOPT options force IPOPT in every tree
IPOPT_OPTIONS = {"hessian_approximation": "exact"}


def with_mode(spec: dict, mode: str) -> dict:
    """``spec`` for ``mode``: ``ipopt`` adds IPOPT_OPTIONS to its solver options, ``scalar``
    leaves it as it is."""
    if mode == "scalar":
        return spec
    solver = dict(spec.get("solver", {}))
    solver["ipopt_options"] = {**solver.get("ipopt_options", {}), **IPOPT_OPTIONS}
    return {**spec, "solver": solver}


def scalar_search() -> str:
    """How this tree's tuner treats one free tunable: ``tuner`` (it has
    ``feedtune.tuner.scalar`` and ``Settings.scalar_search``: the tuner calls the scalar
    search itself) or ``absent`` (IPOPT only)."""
    import dataclasses

    try:
        import feedtune.tuner.scalar  # noqa: F401
        from feedtune.tuner.nlp import Settings
    except ImportError:
        return "absent"
    names = {f.name for f in dataclasses.fields(Settings)}
    return "tuner" if "scalar_search" in names else "absent"


def clear_solver_cache() -> None:
    """This process's solver cache emptied: ``feedtune.tuner.cache`` since issue 15's
    restructuring, ``feedtune.tuner.nlp`` before."""
    try:
        from feedtune.tuner.cache import clear_solver_cache as clear
    except ImportError:
        from feedtune.tuner.nlp import clear_solver_cache as clear
    clear()


class _Recorded:
    """An IPOPT solver whose calls append their ``stats()`` to ``calls`` (for --profile);
    everything else is the solver's own."""

    def __init__(self, solver, calls: list):
        self._solver, self._calls = solver, calls

    def __call__(self, *args, **kwargs):
        try:
            return self._solver(*args, **kwargs)
        finally:
            self._calls.append(self._solver.stats())

    def __getattr__(self, name):
        return getattr(self._solver, name)


def timed_nlpsol(into: dict, key: str, calls: list | None = None):
    """Wrap ``casadi.nlpsol`` (every tree's tuner calls it as ``ca.nlpsol``): its wall time
    is added to ``into[key]``; with ``calls``, the solver records every call's stats.
    Returns the original, for :func:`_restore`."""
    import casadi

    original = casadi.nlpsol

    def nlpsol(*args, **kwargs):
        started = time.perf_counter()
        try:
            solver = original(*args, **kwargs)
        finally:
            into[key] = into.get(key, 0.0) + time.perf_counter() - started
        return solver if calls is None else _Recorded(solver, calls)

    casadi.nlpsol = nlpsol
    return casadi, "nlpsol", original


def _restore(wrapped) -> None:
    for owner, name, original in reversed(wrapped):
        setattr(owner, name, original)


def _tune_once(spec: dict, nlpsol_time: dict) -> dict:
    from feedtune.problem import tune
    from feedtune.schema.spec import parse_spec

    clear_solver_cache()
    nlpsol_time.clear()
    started = time.perf_counter()
    result = tune(parse_spec(spec))
    wall = time.perf_counter() - started
    s = result.solver
    return {"tuning": wall, "build": s.build_time, "nlpsol": nlpsol_time.get("nlpsol", 0.0),
            "solve": s.solve_time, "solve1": s.starts[0].solve_time,
            "evaluation": s.evaluation_time,
            "rest": wall - s.build_time - s.solve_time - s.evaluation_time,
            "starts": len(s.starts), "iterations": sum(st.iterations for st in s.starts),
            "method": s.method,
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


def profile(spec: dict, mode: str) -> dict:
    """Where one tuning's time goes [s], the solver cache cleared (module docstring)."""
    import feedtune.problem as problem_module
    from feedtune.problem import tune
    from feedtune.schema.spec import parse_spec
    from feedtune.tuner import nlp

    parts: dict[str, float] = {}
    calls: list[dict] = []
    wrapped = [timed_nlpsol(parts, "nlpsol (SX expansion, derivatives)", calls),
               _timer(problem_module, "_validation", parts, "validation"),
               _timer(nlp.Problem, "_evaluate_numeric", parts, "evaluation on numbers")]
    if mode == "scalar":
        from feedtune.tuner import scalar

        wrapped += [_timer(scalar.ScalarSearch, "__post_init__", parts, "grid (starts, box ends)"),
                    _timer(scalar.ScalarSearch, "solve_from", parts, "Brent refinements"),
                    _timer(scalar.ScalarSearch, "flat_tunables", parts, "flatness")]
    clear_solver_cache()
    try:
        started = time.perf_counter()
        result = tune(parse_spec(with_mode(spec, mode)))
        parts["tuning"] = time.perf_counter() - started
    finally:
        _restore(wrapped)
    s = result.solver
    parts["build"] = s.build_time
    parts["solve (all starts)"] = s.solve_time
    for key, label in (("nlp_f", "IPOPT objective"), ("nlp_grad_f", "IPOPT gradient"),
                       ("nlp_hess_l", "IPOPT Hessian")):
        if calls:
            parts[f"{label} ({sum(st.get('n_call_' + key, 0) for st in calls)} calls)"] = sum(
                st.get("t_wall_" + key, 0.0) for st in calls)
    parts["starts"] = len(s.starts)
    parts["iterations"] = sum(st.iterations for st in s.starts)
    parts["method"] = s.method
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
    from feedtune.schema.spec import parse_spec

    search = scalar_search()
    modes = ["ipopt"] + (["scalar"] if search == "tuner" else [])
    out = {"load": os.getloadavg()[0], "scalar_search": search}
    nlpsol_time: dict[str, float] = {}
    wrapped = [timed_nlpsol(nlpsol_time, "nlpsol")]
    try:
        for mode in modes:
            for case, spec in CASES.items():
                spec = with_mode(spec, mode)
                tune(parse_spec(spec))  # untimed: IPOPT loaded, first calls paid
                out[f"{case}/{mode}"] = _best([_tune_once(spec, nlpsol_time)
                                               for _ in range(repeats)])
        if free_period:  # two free tunables: IPOPT in every tree
            out["free-period/ipopt"] = _tune_once(FREE_PERIOD, nlpsol_time)
    finally:
        _restore(wrapped)
    out["case3/brent"] = brent_case3(repeats)
    if profiles:
        out["profile"] = {f"{case}/{mode}": profile(spec, mode)
                          for case, spec in CASES.items() for mode in modes}
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
        print(f"  {label}: {path} (scalar search: {runs[label][0]['scalar_search']})")
    print("times in ms, best over rounds; 'tuning' is tune() after imports, solver cache "
          "cleared; 'solve1' the first start")
    keys = [k for k in runs[next(iter(trees))][0] if "/" in k]
    for tree_runs in runs.values():
        keys += [k for k in tree_runs[0] if "/" in k and k not in keys]
    header = f"{'case/mode':<22} {'tree':<6} " + " ".join(f"{t:>10}" for t in TIMES) + \
        f" {'starts':>6} {'iter':>5} {'K 1/s':>14} {'objective':>17}  unique valid success method"
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
                  f"{str(merged.get('success', '-')):>7} {merged.get('method', '-')}")
    for (label, key), row in best.items():
        if key.endswith("/scalar") and row.get("method") != "brent":
            print(f"  note: {label} {key} was solved by {row.get('method')}, not the scalar "
                  "search")
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
