#!/usr/bin/env python
"""Issue 15: Bhatia's hydraulic drive and the Ward-Leonard drive, one tuning each in ≤ 2 s.

Runs the two bundled specs (``examples/bhatia-1971-hydraulic.json``,
``examples/ward-leonard-feed-drive.json``) and 12 seeded random variants of each
(:func:`variants`: every free tunable's box moved, C_v bound 60–150 1/s, M_peak bound
1.1–1.5, every plant constant ×0.8–1.2), tuned with the spec's own solver settings, and
prints per tuning the wall time (parse + build + solve + evaluation + validation), the
bandwidth reached, whether it reaches the best-known optimum (:data:`REFERENCE`, within
REACHED_RTOL), and whether the validator passed.

The baseline ("old") is the previous code, exported from git (``--baseline REV``, default
the commit this work started from) into a temporary directory and run in a child process,
interleaved with the new runs so both see the same machine load: the bundled specs as
they were then (8 and 4 starts, exact Hessian), the variants as here; the table gives
new/old CPU-time ratios and both sides' IPOPT iterations. Both run with one BLAS thread,
as the ``feedtune`` command does. ``--reference`` instead runs the thorough reference of every variant (many
starts, the code on PYTHONPATH) and prints the dictionary to paste into REFERENCE.

Usage::

    .venv/bin/python benchmarks/bhatia_speed.py                 # new + old on the 2 specs, new on 24 variants
    .venv/bin/python benchmarks/bhatia_speed.py --old-variants  # old on the variants too (≈ 25 min)
    .venv/bin/python benchmarks/bhatia_speed.py --no-old        # new only
    .venv/bin/python benchmarks/bhatia_speed.py --only '^bhatia-1971-hydraulic$'  # one spec, old and new (quickest)
"""

from __future__ import annotations

import os

for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")  # as the feedtune command does (feedtune/__main__.py)

import argparse  # noqa: E402
import copy  # noqa: E402
import json  # noqa: E402
import re  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from baseline import export_package, short_revision  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SPECS = ("bhatia-1971-hydraulic", "ward-leonard-feed-drive")
VARIANTS = 12
SEED = 15  # issue 15
#: the commit this work started from (the landed main's tuner)
BASELINE = "65fdeaa"
#: a tuning reaches the best-known optimum when its bandwidth is within this of it (relative):
#: the issue's 1e-4 for Bhatia's 689.774 rad/s
REACHED_RTOL = 1e-4
TARGET_SECONDS = 2.0
#: wall-clock limit of each start in a reference run [s]
REFERENCE_TIME_LIMIT = 900.0
#: box of each compensator time constant when the spec gives none (the plants' defaults) [s]
DEFAULT_TAU_BOX = {"tau1": (1e-4, 10.0), "tau2": (1e-4, 10.0), "tau12": (1e-4, 100.0)}
#: plant fields that are not constants to perturb
NOT_CONSTANTS = {"type", "velocity_compensator", "position_compensator", "stable_velocity_loop"}

#: best-known optimum: bandwidth [rad/s] from a thorough run with 8 starts (``--reference 8``)
#: on 2 cores under load 5-10, 2026-11-25: the two bundled specs and Bhatia variants 01-06
#: with the previous code (65fdeaa; variant 07 hit its 60 s time limit there), Bhatia
#: variants 07-12 and Ward-Leonard variants 01-03 with the new formulation (bb54a23-6edb250;
#: Ward-Leonard variant 04 hit the time limit, 05-12 were not run in time). Every value is
#: a validated, stable, feasible optimum. The bundled Ward-Leonard spec's is from one start of
#: the tuner with warm-started, peak-following exchange rounds kept in the stable region
#: (h-wl, 2026-11-25): 25.5627 rad/s (K'_p = K'_v = 1000, position τ12 = 40.8 s), above the
#: 25.5571 rad/s that 8 starts of the previous tuners found (K'_v = 905, τ12 = 100 s).
#: Ward-Leonard variant 05: 8 starts of the code at 90bb3e2; 04, 06 and 08: 8 starts of
#: h-wl's tuner (load 9-11); 07 and 09-11: 8 starts of main at 0311d56 (2026-11-27, load
#: 10-20, 4-18 min each; 12's run hit the 60 s per-start limit at load 20), exported with ``git archive`` and run in the background with
#: ``OPENBLAS_NUM_THREADS=1 PYTHONPATH=<export> nice -n 19 .venv/bin/python
#: benchmarks/bhatia_speed.py --reference 8 --only 'ward-leonard-feed-drive-variant(07|09|10|11|12)'``.
#: Variant 12: 8 starts of branch h-bspeed (10 exchange points a group) with the reference
#: runs' 900 s per-start limit, 838 s wall at load 19-23 (2026-11-27): the bandwidth one
#: start reaches.
REFERENCE: dict[str, float] = {
    "bhatia-1971-hydraulic": 689.7739082816353,
    "ward-leonard-feed-drive": 25.562727141970303,
    "bhatia-1971-hydraulic-variant01": 730.1984499832166,
    "bhatia-1971-hydraulic-variant02": 544.1906353283963,
    "bhatia-1971-hydraulic-variant03": 701.9113344928676,
    "bhatia-1971-hydraulic-variant04": 799.5321769625574,
    "bhatia-1971-hydraulic-variant05": 674.0181338902814,
    "bhatia-1971-hydraulic-variant06": 710.0536494734812,
    "bhatia-1971-hydraulic-variant07": 728.3211536901289,
    "bhatia-1971-hydraulic-variant08": 817.3431064515905,
    "bhatia-1971-hydraulic-variant09": 597.8133894395507,
    "bhatia-1971-hydraulic-variant10": 594.2351776776985,
    "bhatia-1971-hydraulic-variant11": 691.6037305638166,
    "bhatia-1971-hydraulic-variant12": 531.4980741433311,
    "ward-leonard-feed-drive-variant01": 21.012053724738568,
    "ward-leonard-feed-drive-variant02": 29.04832744477611,
    "ward-leonard-feed-drive-variant03": 24.476051917881513,
    "ward-leonard-feed-drive-variant04": 25.268096187404634,
    "ward-leonard-feed-drive-variant05": 26.3928312704574,
    "ward-leonard-feed-drive-variant06": 26.89975429429867,
    "ward-leonard-feed-drive-variant07": 25.29636374416465,
    "ward-leonard-feed-drive-variant08": 22.02674332875889,
    "ward-leonard-feed-drive-variant09": 24.273794134051414,
    "ward-leonard-feed-drive-variant10": 31.549632193699885,
    "ward-leonard-feed-drive-variant11": 29.52502487391483,
    "ward-leonard-feed-drive-variant12": 28.01675393346347,
}


def load(name: str) -> dict:
    with open(os.path.join(ROOT, "examples", f"{name}.json")) as fh:
        return json.load(fh)


def variants(name: str, count: int = VARIANTS, seed: int = SEED) -> list[dict]:
    """``count`` seeded random variants of the bundled spec ``name``.

    Each free tunable's box: min and max each times 10^U(−0.5, 0.5) (decades; the plant's
    default box where the spec gives none), the initial point clipped into the new box;
    the C_v bound U(60, 150) 1/s; the M_peak bound U(1.1, 1.5); every numeric plant
    constant times U(0.8, 1.2). The sensitivity bound and the objective are the spec's.
    """
    rng = np.random.default_rng([seed, SPECS.index(name)])
    out = []
    for k in range(count):
        spec = copy.deepcopy(load(name))
        spec["name"] = f"{name}-variant{k + 1:02d}"
        for key, value in spec["plant"].items():
            if key not in NOT_CONSTANTS and isinstance(value, (int, float)):
                spec["plant"][key] = float(value * rng.uniform(0.8, 1.2))
        for tname, tunable in spec["tunables"].items():
            lo, hi = tunable.get("min"), tunable.get("max")
            if lo is None or hi is None:
                lo, hi = DEFAULT_TAU_BOX[tname.split(".")[-1]]
            lo *= 10 ** rng.uniform(-0.5, 0.5)
            hi *= 10 ** rng.uniform(-0.5, 0.5)
            tunable["min"], tunable["max"] = float(lo), float(hi)
            if "initial" in tunable:
                tunable["initial"] = float(min(max(tunable["initial"], lo), hi))
        for c in spec["constraints"]:
            if c["metric"] == "velocity_constant":
                c["min"] = float(rng.uniform(60, 150))
            elif c["metric"] == "m_peak":
                c["max"] = float(rng.uniform(1.1, 1.5))
        out.append(spec)
    return out


def all_specs() -> list[dict]:
    """The two bundled specs, then 12 variants of each."""
    return [load(n) for n in SPECS] + [v for n in SPECS for v in variants(n)]


def tune_one(spec: dict, solver: dict | None = None) -> dict:
    """Tune ``spec`` (optionally with other solver settings) with the feedtune on sys.path."""
    from feedtune.problem import tune
    try:
        from feedtune.schema.spec import parse_spec
    except ImportError:  # a baseline from before the package layout of 6c1ee9d
        from feedtune.spec import parse_spec

    spec = copy.deepcopy(spec)
    if solver is not None:
        spec["solver"] = {**spec.get("solver", {}), **solver}
    started, cpu = time.perf_counter(), time.process_time()
    result = tune(parse_spec(spec))
    seconds, cpu = time.perf_counter() - started, time.process_time() - cpu
    bandwidth = result.metrics["bandwidth"].value if result.success else None
    return {"name": spec["name"], "seconds": seconds, "cpu": cpu, "bandwidth": bandwidth,
            "status": result.status, "success": result.success,
            "validation_ok": result.validation.get("ok"),
            "starts": len(result.solver.starts),
            "iterations": sum(s.iterations for s in result.solver.starts),
            "tuned": {k: v.value for k, v in result.tuned.items()}}


def warm_up() -> None:
    """Imports and IPOPT's first load, paid before any timing (one tiny solve)."""
    tune_one(load(SPECS[1]), {"multistart": 1, "max_iter": 1})


def _child(argv) -> int:
    """``--child``: tune the specs given as JSON on stdin, one JSON line per result."""
    specs = json.load(sys.stdin)
    warm_up()
    for spec in specs:
        print(json.dumps(tune_one(spec)), flush=True)
    return 0


class Baseline:
    """The previous code in a child process: ``git archive REV`` unpacked into a temp dir."""

    def __init__(self, rev: str):
        self.dir = str(export_package(rev, Path(tempfile.mkdtemp(prefix="feedtune-baseline-"))))
        self.rev = short_revision(rev)

    def spec(self, name: str) -> dict:
        """The bundled spec ``name`` as it was at the baseline (its own solver settings)."""
        text = subprocess.run(["git", "-C", ROOT, "show", f"{self.rev}:examples/{name}.json"],
                              check=True, capture_output=True, text=True).stdout
        return json.loads(text)

    def tune(self, spec: dict) -> dict:
        """Tune ``spec`` with the old code (the bundled specs as they were then)."""
        if spec["name"] in SPECS:
            spec = self.spec(spec["name"])
        env = {**os.environ, "PYTHONPATH": self.dir}
        proc = subprocess.run([sys.executable, os.path.abspath(__file__), "--child"],
                              input=json.dumps([spec]), capture_output=True, text=True, env=env,
                              cwd=self.dir, check=True)
        return json.loads(proc.stdout.strip().splitlines()[-1])


def reached(run: dict | None, best: float | None) -> str:
    """yes/no against the best-known optimum; n/a without a reference run for the spec."""
    if run is None:
        return "-"
    if best is None:
        return "n/a"
    if run["bandwidth"] is None:
        return "no"
    return "yes" if run["bandwidth"] >= best * (1 - REACHED_RTOL) else "no"


def reference(multistart: int, only: str | None = None) -> int:
    """Thorough reference: every spec (whose name matches the regex ``only``) with ``multistart``
    starts; prints REFERENCE."""
    found = {}
    for spec in all_specs():
        if only and not re.search(only, spec["name"]):
            continue
        # a start's wall-clock limit (60 s by default) is protection, not part of the
        # reference: at load 10-20 it cut variant 12's starts short
        run = tune_one(spec, {"multistart": multistart, "time_limit": REFERENCE_TIME_LIMIT})
        found[spec["name"]] = run["bandwidth"]
        print(f"# {spec['name']}: {run['bandwidth']} rad/s, {run['status']}, validation "
              f"{run['validation_ok']}, {run['seconds']:.1f} s", flush=True)
    print("REFERENCE = " + json.dumps(found, indent=4))
    return 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", default=BASELINE, help="git revision of the old code")
    parser.add_argument("--no-old", action="store_true", help="do not run the old code")
    parser.add_argument("--old-variants", action="store_true",
                        help="run the old code on the 24 variants too (slow)")
    parser.add_argument("--reference", type=int, metavar="STARTS",
                        help="run the thorough reference with this many starts and print it")
    parser.add_argument("--only", metavar="REGEX",
                        help="only specs whose name matches this regular expression (e.g. "
                             "'^bhatia-1971-hydraulic$' for the quickest run)")
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        return _child(argv)
    if args.reference:
        return reference(args.reference, args.only)

    import casadi

    import feedtune

    baseline = None if args.no_old else Baseline(args.baseline)
    load_start = os.getloadavg()
    warm_up()
    print(f"feedtune {feedtune.__file__}; casadi {casadi.__version__}; python "
          f"{sys.version.split()[0]}; baseline: "
          f"{'none' if baseline is None else baseline.rev + ' (child process, same specs)'}")
    print(f"load average at start {load_start[0]:.2f} {load_start[1]:.2f} {load_start[2]:.2f} on "
          f"{os.cpu_count()} CPUs; time = parse + build + solve + evaluation + validation")
    header = (f"{'spec':<36} {'new s':>6} {'cpu s':>6} {'bandwidth':>10} {'best':>10} "
              f"{'reached':>7} {'valid':>5} {'starts':>6} {'iters':>6} | {'old s':>6} "
              f"{'cpu s':>6} {'iters':>6} {'reached':>7} {'new/old':>7}")
    print(header)
    print("-" * len(header))
    rows = []
    for spec in all_specs():
        if args.only and not re.search(args.only, spec["name"]):
            continue
        bundled = spec["name"] in SPECS
        new = tune_one(spec)
        old = (baseline.tune(spec) if baseline is not None and (bundled or args.old_variants)
               else None)
        reference_value = REFERENCE.get(spec["name"])
        # best known: the reference run's, or a better one found here (then it is the best)
        best = (None if reference_value is None else
                max(b for b in (reference_value, new["bandwidth"], old and old["bandwidth"])
                    if b is not None))
        rows.append((spec["name"], new, old, best))
        ratio = f"{new['cpu'] / old['cpu']:7.3f}" if old else f"{'-':>7}"
        print(f"{spec['name']:<36} {new['seconds']:6.2f} {new['cpu']:6.2f} "
              f"{new['bandwidth'] if new['bandwidth'] is not None else float('nan'):10.4f} "
              f"{best if best is not None else float('nan'):10.4f} {reached(new, best):>7} "
              f"{'yes' if new['validation_ok'] else 'NO':>5} {new['starts']:6d} "
              f"{new['iterations']:6d} | "
              f"{old['seconds'] if old else float('nan'):6.2f} "
              f"{old['cpu'] if old else float('nan'):6.2f} "
              f"{old['iterations'] if old else '-':>6} {reached(old, best):>7} {ratio}",
              flush=True)
    print()
    for name in SPECS:
        group = [r for r in rows if r[0].startswith(name) and r[0] != name]
        ok = sum(reached(new, best) == "yes" and new["seconds"] <= TARGET_SECONDS
                 and new["validation_ok"] for _, new, _, best in group)
        found = sum(reached(new, best) == "yes" for _, new, _, best in group)
        known = sum(best is not None for _, _, _, best in group)
        ok_cpu = sum(reached(new, best) == "yes" and new["cpu"] <= TARGET_SECONDS
                     and new["validation_ok"] for _, new, _, best in group)
        times = [new["seconds"] for _, new, _, _ in group]
        cpus = [new["cpu"] for _, new, _, _ in group]
        if not group:  # --only left none of them
            continue
        print(f"{name} variants: {found} of {known} with a reference reach the best-known "
              f"optimum, {ok} of them in ≤ {TARGET_SECONDS:g} s with validation ok (target: "
              f"≥ 10 of 12), {ok_cpu} in ≤ {TARGET_SECONDS:g} s of CPU; time median "
              f"{np.median(times):.2f} s, max {max(times):.2f} s; CPU median {np.median(cpus):.2f} "
              f"s, max {max(cpus):.2f} s")
    for name, new, old, best in rows:
        if name in SPECS:
            print(f"{name}: new {new['seconds']:.2f} s, {new['cpu']:.2f} s CPU "
                  f"({reached(new, best)}, validation {new['validation_ok']}), old "
                  + (f"{old['seconds']:.2f} s, {old['cpu']:.2f} s CPU ({reached(old, best)}); "
                     f"new/old CPU {new['cpu'] / old['cpu']:.3f}" if old else "not run"))
    end = os.getloadavg()
    print(f"load average at end {end[0]:.2f} {end[1]:.2f} {end[2]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
