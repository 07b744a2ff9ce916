"""Tian's pulse generator (issue 15): time per tuning and peak memory, old against new.

Tunes ``examples/tian-vf-pulse.json`` (differential evolution on the exact pulse
simulation, 1 start × 40 generations) with this checkout's feedtune and with the
baseline commit's (``--baseline``, default the commit before the issue 15 work on the
pulse generator), each run in a fresh process, the two interleaved ``--repeat`` times so
load from elsewhere hits both alike. Each child reports its time inside ``tune`` (after
imports) and its tuned values; the parent reads each child's own peak memory (maximum
resident set size, ``os.wait4``). The baseline's code is exported with ``git archive``
into a temporary directory, so nothing in the work tree changes.

The bundled spec tunes from one start (since issue 15; it had 2); a third side runs this
tree's feedtune with ``solver.multistart`` 2, the cost of a second start (the example's
best start is its first, so the tuned values must not change; the spec itself is not
edited). Each child imports only feedtune's ``tune`` and ``parse_spec`` before the timed
``tune``, so the new side's time is a first tuning in a fresh process, with what the
search imports when it first runs (``scipy.optimize``); the old tree loaded
``scipy.optimize`` and ``scipy.stats`` with feedtune, before its clock starts.

Since issue 15's last change the search's initial population is scipy's Latin hypercube
instead of a Sobol sequence (which imported ``scipy.stats``, 0.25 s of a fresh process), so
the tuned values differ from the baseline's: the settling times (the objective) are
compared against one sampling period of the baseline's tuning, the scale the settling
time is measured on.

Printed: per side the median time per tuning [s] (wall, and the child's CPU time inside
``tune``, which a loaded machine disturbs less), the median peak RSS [MB], the number of
simulations, the tuned values and objective (which must agree), the ratios old/new and
issue 15's targets (≤ 1 s per tuning, ≤ 300 MB peak), and the load average before and
after. ``--profile`` adds the new side's cProfile (top functions by own time).

Run: ``.venv/bin/python benchmarks/tian_speed.py [--repeat N] [--baseline REV] [--profile]``
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from baseline import export_package

REPO = Path(__file__).resolve().parents[1]
EXAMPLE = REPO / "examples" / "tian-vf-pulse.json"
BASELINE = "65fdeaa"  # main before the pulse generator's issue 15 work
TARGET_TIME = 1.0  # s per tuning (issue 15)
TARGET_RSS = 300.0  # MB peak (issue 15)

CHILD = r"""
import json, sys, time
started = time.perf_counter()
from feedtune.problem import tune
try:
    from feedtune.schema.spec import parse_spec
except ModuleNotFoundError:  # a tree from before the package layout (issue 16)
    from feedtune.spec import parse_spec
imported = time.perf_counter()
raw = json.loads(open(sys.argv[1]).read())
if len(sys.argv) > 2:
    raw["solver"]["multistart"] = int(sys.argv[2])
spec = parse_spec(raw)
begun, cpu = time.perf_counter(), time.process_time()
result = tune(spec)
done, cpu = time.perf_counter(), time.process_time() - cpu
print(json.dumps({"imports": imported - started, "tune": done - begun, "cpu": cpu,
                  "tuned": {k: v.value for k, v in result.tuned.items()},
                  "objective": result.objective, "message": result.solver.message,
                  "status": result.status, "scipy_stats": "scipy.stats" in sys.modules}))
"""

PROFILE = r"""
import cProfile, json, pstats, sys
from feedtune.problem import tune
try:
    from feedtune.schema.spec import parse_spec
except ModuleNotFoundError:  # a tree from before the package layout (issue 16)
    from feedtune.spec import parse_spec
spec = parse_spec(json.loads(open(sys.argv[1]).read()))
profile = cProfile.Profile()
profile.runcall(tune, spec)
pstats.Stats(profile).sort_stats("tottime").print_stats(12)
"""


def run(code: str, path: Path, multistart: int | None = None) -> tuple[dict, float]:
    """One child with ``path`` first on sys.path (``multistart`` overriding the spec's):
    (its JSON report, its peak RSS [MB])."""
    env = dict(os.environ, PYTHONPATH=str(path), OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1",
               MKL_NUM_THREADS="1")
    extra = [] if multistart is None else [str(multistart)]
    proc = subprocess.Popen([sys.executable, "-c", code, str(EXAMPLE), *extra], stdout=subprocess.PIPE,
                            cwd=path, env=env, text=True)
    out = proc.stdout.read()
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode:
        raise SystemExit(f"child failed ({path}): exit {proc.returncode}")
    return json.loads(out.strip().splitlines()[-1]), usage.ru_maxrss / 1024.0  # kB on Linux


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="tunings per side [count]")
    parser.add_argument("--baseline", default=BASELINE, help="git revision of the old side")
    parser.add_argument("--profile", action="store_true", help="print the new side's profile")
    args = parser.parse_args()
    print(f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())} "
          f"({os.cpu_count()} CPUs)")
    with tempfile.TemporaryDirectory() as tmp:
        old = export_package(args.baseline, Path(tmp))
        sides = {f"old ({args.baseline})": (old, None), "new (this tree)": (REPO, None),
                 "new, 2 starts": (REPO, 2)}
        runs: dict[str, list[tuple[dict, float]]] = {name: [] for name in sides}
        for _ in range(args.repeat):
            for name, (path, multistart) in sides.items():
                runs[name].append(run(CHILD, path, multistart))
        print(f"\n{'side':<16} {'tune [s]':>9} {'CPU [s]':>8} {'imports [s]':>11} {'peak RSS [MB]':>13}"
              f"  status, simulations")
        medians = {}
        for name, rows in runs.items():
            tune_s = statistics.median(r["tune"] for r, _ in rows)
            cpu = statistics.median(r["cpu"] for r, _ in rows)
            rss = statistics.median(m for _, m in rows)
            imports = statistics.median(r["imports"] for r, _ in rows)
            medians[name] = (tune_s, cpu, rss)
            report = rows[0][0]
            simulations = report["message"].split("(")[-1].rstrip(")").split(", ")[-1]
            print(f"{name:<16} {tune_s:>9.3f} {cpu:>8.3f} {imports:>11.3f} {rss:>13.1f}  {report['status']}, "
                  f"{simulations}, scipy.stats imported: {report['scipy_stats']}  "
                  f"(runs: {', '.join(format(r['tune'], '.3f') for r, _ in rows)} s)")
        (old_t, old_c, old_m), (new_t, new_c, new_m), (one_t, one_c, one_m) = medians.values()
        print(f"\nratio old/new: wall {old_t / new_t:.1f}x, CPU {old_c / new_c:.1f}x, "
              f"peak memory {old_m / new_m:.1f}x; old/new with 2 starts: wall {old_t / one_t:.1f}x, "
              f"CPU {old_c / one_c:.1f}x")
        for name, (t, c, m) in list(medians.items())[1:]:
            verdict = "met" if t <= TARGET_TIME else ("met in CPU time" if c <= TARGET_TIME else "NOT met")
            print(f"issue 15 targets, {name}: <= {TARGET_TIME} s per tuning: {verdict} "
                  f"(wall {t:.3f} s, CPU {c:.3f} s); <= {TARGET_RSS:.0f} MB peak: "
                  f"{'met' if m <= TARGET_RSS else 'NOT met'} ({m:.0f} MB)")
        print("\ntuned values and objective:")
        reports = {name: rows[0][0] for name, rows in runs.items()}
        for name, report in reports.items():
            values = ", ".join(f"{k} = {v!r}" for k, v in report["tuned"].items())
            print(f"  {name:<16} {values}; objective {report['objective']!r}")
        old_r, new_r, two_r = reports.values()
        period = 1.0 / old_r["tuned"]["sampling_frequency"]  # [s] the baseline's
        gap = new_r["objective"] - old_r["objective"]
        print(f"  new - old objective: {gap * 1e6:+.2f} us = {gap / period:+.2f} of the baseline's "
              f"sampling period ({period * 1e6:.2f} us): "
              f"{'within one period' if abs(gap) <= period else 'NOT within one period'}")
        same = new_r["tuned"] == two_r["tuned"] and new_r["objective"] == two_r["objective"]
        print(f"  2 starts identical to 1 start: {same}")
        print(f"\nload average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
        if args.profile:
            print("\nprofile of the new side (one tuning):")
            env = dict(os.environ, PYTHONPATH=str(REPO))
            subprocess.run([sys.executable, "-c", PROFILE, str(EXAMPLE)], cwd=REPO, env=env,
                           check=True)


if __name__ == "__main__":
    main()
