#!/usr/bin/env python
"""Batch throughput: specs per second with 1 worker and with all cores, against single
solves in this process, side by side in one run.

N software-servo specs are generated deterministically from the two Koren 1979 examples
(``examples/koren-1979-sampled-data.json``, ``examples/koren-1979-reference-pulse.json``),
varying the drive (τ, BLU, V_m), the circle's feed, the sampling period (fixed, or free
within varied bounds), the constraints (damping ratio bounds, f_m·T ≥ 100 for a free T)
and the number of multistarts (2–4), so each costs about 0.03–0.1 s to tune. Then:

a. single solves: ``parse_spec`` + ``tune`` here, one after another, on the first
   ``--sample`` specs (default 100), after one untimed solve of each kind of problem (so
   imports and IPOPT's first load are not counted) and, when ``feedtune.tuner.cache`` has
   it, ``clear_solver_cache()``. The solver cache keys on the serialized CasADi graph;
   τ, BLU and V_m are NLP parameters, but the circle (radius, feed) and the sampling box
   shape the graph, so these generated specs share few solvers (the printed hit rate
   shows how many);
b. the batch, ``feedtune.batch.runner.run_batch`` with ``LocalExecutor(workers=W)`` for
   each W of ``--workers`` (default: 1 and all cores), each into a fresh directory — the
   whole of it: reading the specs, spawning workers (imports, solver builds), IPC,
   writing each result and the summary;
   then the largest worker count again with spawned workers (each a fresh interpreter
   importing the tuner itself, as before issue 15), side by side with the default, where
   workers are forked from this process (``feedtune.batch.local.start_method``). Every
   mode runs with one BLAS thread per process, as the ``feedtune`` command sets it
   (``feedtune.__main__.pin_blas_threads``; set here before numpy loads);
c. a resumed rerun of the last batch's directory (every result already there: each spec
   is parsed and hashed, nothing is solved);
d. with ``--dask``, the same batch on a local Dask cluster of the largest worker count
   (``DaskExecutor``: the cluster's start, its worker processes' start-up and their first
   specs included), its result files compared with the local executor's field by field
   (:func:`compare_results`): the executors must give the same results.

It prints one table: specs/s and ms/spec (wall) per mode, the batch's per-spec overhead
relative to a single solve, (batch s/spec − single s/spec) / single s/spec, the speed-up
of each worker count over 1 worker, the mean time inside ``solve`` per spec (the summary
rows' ``time``: parse + tune as a worker measured it) and CPU ms/spec (this process and
its worker processes: the joined ones and, for the Dask cluster's, those still running
or reaped by another of them, e.g. multiprocessing's forkserver; :func:`_cpu`), which tell
contention on a shared machine from overhead.
With ``feedtune.tuner.cache.solver_cache_info()`` (when it exists) it also prints this
process's solver-cache hit rate over the single solves.

With ``--baseline REV`` it measures git revision REV's ``feedtune`` (exported with
``git archive`` into a temporary directory) and this checkout's, alternately, ``--rounds``
times, each run in a fresh process, and prints the ratios mode by mode (current over
baseline: specs/s, and CPU per spec the other way round, so > 1 is better for both),
with the load average of each run: on a shared machine the runs of a pair see nearly the
same load. It then compares the two first runs' result files (the largest worker count's
batch) field by field, clocks and provenance aside (:func:`compare_results`): a change
meant to be faster only should leave every one equal.

    .venv/bin/python benchmarks/batch_throughput.py                 # 2000 specs
    .venv/bin/python benchmarks/batch_throughput.py --specs 300 --workers 1 2 --keep
    .venv/bin/python benchmarks/batch_throughput.py --specs 300 --workers 1 2 --baseline main
    .venv/bin/python benchmarks/batch_throughput.py --specs 150 --workers 2 --dask --baseline main
"""

from __future__ import annotations

import os

# one BLAS thread, as the `feedtune` command sets it, before anything loads numpy (a forked
# worker keeps the BLAS set-up of this process)
for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import argparse  # noqa: E402
import copy  # noqa: E402
import json  # noqa: E402
import resource  # noqa: E402
import shutil  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from collections import Counter  # noqa: E402
from pathlib import Path  # noqa: E402

from baseline import export_package, short_revision  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
#: the feedtune measured: this checkout, or another one's tree (set by --baseline)
TREE = Path(os.environ.get("FEEDTUNE_BENCH_TREE") or REPO)
sys.path.insert(0, str(TREE))

from feedtune.batch.local import LocalExecutor, default_workers  # noqa: E402
from feedtune.batch.runner import run_batch  # noqa: E402
from feedtune.problem import tune  # noqa: E402
from feedtune.schema.spec import parse_spec  # noqa: E402

SAMPLED = json.loads((REPO / "examples" / "koren-1979-sampled-data.json").read_text())
PULSE = json.loads((REPO / "examples" / "koren-1979-reference-pulse.json").read_text())


# -- the specs --------------------------------------------------------------------------

def _spread(i: int, count: int, low: float, high: float, geometric: bool = True) -> float:
    """The ``i mod count``-th of ``count`` points between low and high (a fixed grid)."""
    u = (i % count) / max(count - 1, 1)
    return low * (high / low) ** u if geometric else low + (high - low) * u


def generate(n: int) -> list[dict]:
    """``n`` distinct, deterministic software-servo specs (no randomness: i → spec).

    Kinds rotate: reference pulse; sampled data with T fixed; sampled data with T free
    (and for half of those f_m·T ≥ 100). The grids have coprime sizes, so the
    combinations repeat only after thousands of specs.
    """
    specs = []
    for i in range(n):
        kind = i % 3
        spec = copy.deepcopy(PULSE if kind == 0 else SAMPLED)
        tau = _spread(i, 7, 0.01, 0.05)
        blu = _spread(i, 5, 1e-6, 1e-5)
        v_max = _spread(i, 11, 0.02, 0.1)
        spec["name"] = f"servo-{i:05d}"
        spec["description"] = f"generated by benchmarks/batch_throughput.py, spec {i}"
        spec["plant"].update(time_constant=round(tau, 6), blu=round(blu, 9),
                             max_velocity=round(v_max, 5))
        spec["objective"][0]["feed"] = round(v_max * _spread(i, 4, 0.5, 1.0, False), 6)
        spec["objective"][0]["radius"] = round(_spread(i, 13, 0.004, 0.02), 6)
        spec["tunables"]["position_gain"] = {"min": 1.0, "max": round(_spread(i, 3, 100, 300), 3)}
        zeta = round(_spread(i, 9, 0.3, 0.7, False), 4)
        constraints = [{"metric": "damping_ratio", "min": zeta}]
        if i % 17 == 0:
            constraints[0]["max"] = 1.5
        if kind == 1:
            period = round(_spread(i, 6, 1 / 128, 1 / 32), 8)
            spec["tunables"]["sampling_period"] = {"value": period}
        elif kind == 2:
            spec["tunables"]["sampling_period"] = {
                "min": round(_spread(i, 4, 0.001, 0.004), 6),
                "max": round(_spread(i, 5, 0.02, 0.06), 6)}
            if i % 2:
                constraints.append({"metric": "encoder_ratio", "min": 100})
        spec["constraints"] = constraints
        spec["solver"] = {"multistart": 2 + i % 3}
        specs.append(spec)
    return specs


def one_spec_per_structure(specs: list[dict]) -> list[dict]:
    """The last spec of each kind of problem (:func:`_structure`): solved once, untimed,
    before a measurement, so imports, IPOPT's first load and solver builds are not counted."""
    warm: dict[tuple, dict] = {}
    for spec in reversed(specs):
        warm.setdefault(_structure(spec), spec)
    return list(warm.values())


def _structure(spec: dict) -> tuple:
    """The kind of problem: technique, which tunables are free, which constraints."""
    return (spec["plant"].get("technique"),
            json.dumps({k: sorted(v) for k, v in spec["tunables"].items()}, sort_keys=True),
            tuple((c["metric"], "min" in c, "max" in c) for c in spec["constraints"]))


# -- measurements ------------------------------------------------------------------------

def single_solves(specs: list[dict], sample: int) -> dict:
    """parse_spec + tune in this process on the first ``sample`` specs (every kind and
    grid rotates with the index, so they mix like the whole set; a stride could alias
    with the kinds), after untimed warm-ups."""
    chosen = [json.dumps(s).encode() for s in specs[:sample]]
    warm: dict[tuple, dict] = {}
    for spec in reversed(specs):  # from the end: outside the sample unless N is small
        warm.setdefault(_structure(spec), spec)
    started = time.perf_counter()
    for spec in warm.values():
        tune(parse_spec(json.dumps(spec)))
    warm_time = time.perf_counter() - started
    clear = getattr(_nlp(), "clear_solver_cache", None)
    if clear is not None:
        clear()
    info = getattr(_nlp(), "solver_cache_info", None)
    before = info() if info else None
    statuses: Counter = Counter()
    cpu, started = time.process_time(), time.perf_counter()
    for data in chosen:
        statuses[tune(parse_spec(data)).status] += 1
    wall = time.perf_counter() - started
    return {"count": len(chosen), "wall": wall, "statuses": statuses, "solve": wall,
            "cpu": time.process_time() - cpu,
            "warmups": len(warm), "warm_time": warm_time,
            "cache": _cache_rate(before, info()) if info else None}


def _chooses_start() -> bool:
    """Whether this tree's LocalExecutor takes a start method (since issue 15)."""
    import inspect

    return "start" in inspect.signature(LocalExecutor).parameters


def _nlp():
    """The module holding the solver cache: feedtune.tuner.cache, or feedtune.tuner.nlp in a
    tree before issue 15's restructuring (a --baseline)."""
    try:
        import feedtune.tuner.cache as cache
    except ImportError:
        import feedtune.tuner.nlp as cache
    return cache


def _counts(info) -> tuple[int, int] | None:
    """(hits, misses) from a CacheInfo-like object or a dict, if it has them."""
    if isinstance(info, dict):
        hits, misses = info.get("hits"), info.get("misses")
    else:
        hits, misses = getattr(info, "hits", None), getattr(info, "misses", None)
    return (hits, misses) if isinstance(hits, int) and isinstance(misses, int) else None


def _cache_rate(before, after) -> str:
    b, a = _counts(before), _counts(after)
    if a is None:
        return f"solver_cache_info() = {after!r}"
    hits, misses = (a[0] - b[0], a[1] - b[1]) if b else a
    total = hits + misses
    rate = f"{hits / total:.1%}" if total else "n/a"
    return f"{rate} ({hits} hits, {misses} misses over the timed single solves; now {after!r})"


def batch(spec_dir: Path, out: Path, workers: int, start: str | None = None,
          dask: bool = False) -> dict:
    """One run_batch of every spec in ``spec_dir`` into ``out`` (``start``: the workers'
    start method, when not the executor's default; ``dask``: on a local Dask cluster of
    ``workers`` processes instead)."""
    cpu = _cpu()
    if dask:
        from feedtune.batch.dask_cluster import DaskExecutor

        executor = DaskExecutor(workers=workers)
    else:
        executor = (LocalExecutor(workers=workers) if start is None
                    else LocalExecutor(workers=workers, start=start))
    outcome = run_batch([str(spec_dir)], out, executor)
    document = outcome.document
    return {"count": document["specs"], "wall": outcome.wall,
            "statuses": Counter(document["counts"]),
            "solve": sum(r["time"] for r in document["rows"]), "cpu": _cpu() - cpu,
            "resumed": sum(1 for r in document["rows"] if r.get("resumed"))}


def _cpu() -> float:
    """CPU seconds of this process and of every process started below it: the finished
    (joined) children, the workers, and on Linux (``/proc``) every descendant still running
    with the children it has reaped itself (a Dask cluster's forkserver keeps running, and
    its worker processes are its children, not this process's)."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    total = own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime
    return total + _running_descendants_cpu()


def _running_descendants_cpu() -> float:
    """utime + stime + cutime + cstime of every running descendant (Linux; else 0)."""
    try:
        tick = os.sysconf("SC_CLK_TCK")
        parents, times = {}, {}
        for entry in os.listdir("/proc"):
            if not entry.isdigit():
                continue
            try:
                with open(f"/proc/{entry}/stat") as stat:
                    fields = stat.read().rpartition(")")[2].split()
            except OSError:  # gone meanwhile
                continue
            parents[int(entry)] = int(fields[1])
            times[int(entry)] = sum(int(f) for f in fields[11:15]) / tick
    except (OSError, ValueError, AttributeError):
        return 0.0
    below, frontier = set(), {os.getpid()}
    while frontier:
        frontier = {pid for pid, parent in parents.items() if parent in frontier} - below
        below |= frontier
    return sum(times[pid] for pid in below)


# -- report ------------------------------------------------------------------------------

def _row(label: str, m: dict, single: float | None, one_worker: float | None) -> str:
    per = m["wall"] / m["count"]
    overhead = f"{(per - single) / single:+.2f}" if single else "–"
    speedup = f"{one_worker / per:.2f}" if one_worker else "–"
    return (f"| {label} | {m['count']} | {m['wall']:.2f} | {m['count'] / m['wall']:.1f} | "
            f"{per * 1e3:.1f} | {overhead} | {speedup} | {m['solve'] / m['count'] * 1e3:.1f} | "
            f"{m['cpu'] / m['count'] * 1e3:.1f} |")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--specs", type=int, default=2000, help="number of generated specs")
    parser.add_argument("--workers", type=int, nargs="+", default=None,
                        help="worker counts of the batch runs (default: 1 and all cores)")
    parser.add_argument("--sample", type=int, default=100,
                        help="specs solved one by one in this process (default 100)")
    parser.add_argument("--keep", action="store_true",
                        help="keep the generated specs and results (the directory is printed)")
    parser.add_argument("--baseline", metavar="REV",
                        help="also measure git revision REV's feedtune, alternating with this one")
    parser.add_argument("--rounds", type=int, default=1,
                        help="with --baseline: pairs of runs (baseline, current)")
    parser.add_argument("--dask", action="store_true",
                        help="also run the batch on a local Dask cluster (the largest worker "
                             "count), last, and compare its results with the local executor's")
    parser.add_argument("--json", metavar="FILE", help=argparse.SUPPRESS)  # for --baseline
    # for --baseline: keep the largest worker count's result files in this directory
    parser.add_argument("--results", metavar="DIR", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.baseline:
        return compare(args, sys.argv[1:] if argv is None else argv)
    cores = default_workers()
    workers = args.workers or sorted({1, cores})
    if 1 not in workers:
        workers = [1, *workers]

    root = Path(tempfile.mkdtemp(prefix="feedtune-batch-bench-"))
    try:
        spec_dir = root / "specs"
        spec_dir.mkdir()
        specs = generate(args.specs)
        for spec in specs:
            (spec_dir / f"{spec['name']}.json").write_text(json.dumps(spec, indent=1))
        load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
        print(f"{args.specs} specs, feedtune from {TREE}, {cores} cores available, load {load:.2f}, "
              f"python {sys.version.split()[0]}", file=sys.stderr)

        single = single_solves(specs, min(args.sample, args.specs))
        single_per = single["wall"] / single["count"]
        print(f"single solves done ({single['count']}, {single['wall']:.1f} s)", file=sys.stderr)
        runs = {}
        for w in workers:
            runs[w] = batch(spec_dir, root / f"out-{w}", w)
            print(f"batch with {w} worker(s) done ({runs[w]['wall']:.1f} s)", file=sys.stderr)
        last = workers[-1]
        # spawned workers, as before issue 15 (a tree whose executor cannot choose: none)
        spawned = (batch(spec_dir, root / f"out-{last}-spawned", last, start="spawn")
                   if _chooses_start() else None)
        resumed = batch(spec_dir, root / f"out-{last}", last)
        # last: a Dask client leaves threads here, after which local workers would spawn
        dask = batch(spec_dir, root / f"out-{last}-dask", last, dask=True) if args.dask else None
        if args.results:
            shutil.copytree(root / f"out-{last}", args.results, dirs_exist_ok=True)
        load_after = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")

        one = runs[1]["wall"] / runs[1]["count"]
        print()
        print(f"{args.specs} generated software-servo specs; {cores} cores; load average "
              f"{load:.2f} before, {load_after:.2f} after")
        print()
        print("| mode | specs | wall s | specs/s | ms/spec | overhead vs single | "
              "speed-up vs 1 worker | in-solve ms/spec | CPU ms/spec |")
        print("|---|---|---|---|---|---|---|---|---|")
        print(_row(f"single solve in process (first {single['count']}; {single['warmups']} "
                   f"kinds warmed up first, {single['warm_time']:.2f} s, not counted)",
                   single, None, None))
        for w in workers:
            print(_row(f"batch, {w} worker{'s' if w > 1 else ''}", runs[w], single_per,
                       one if w != 1 else None))
        if spawned is not None:
            print(_row(f"batch, {last} worker{'s' if last > 1 else ''}, spawned (each imports "
                       "the tuner itself)", spawned, single_per, one))
        print(_row(f"resumed rerun, {last} worker{'s' if last > 1 else ''} (nothing solved)",
                   resumed, None, one))
        if dask is not None:
            print(_row(f"batch, local Dask cluster of {last} worker{'s' if last > 1 else ''} "
                       "(its start included)", dask, single_per, one))
        print()
        for label, m in [("single", single), *((f"batch {w}", runs[w]) for w in workers),
                         ("resumed", resumed), *((("dask", dask),) if dask else ())]:
            counts = ", ".join(f"{n} {s}" for s, n in sorted(m["statuses"].items()))
            print(f"statuses, {label}: {counts}")
        if resumed["resumed"] != resumed["count"]:
            print(f"WARNING: only {resumed['resumed']} of {resumed['count']} rows resumed")
        if dask is not None:
            print(f"Dask against the local executor ({last} workers): "
                  + compare_results(root / f"out-{last}", root / f"out-{last}-dask"))
        cache = single["cache"]
        print("solver cache, single solves: " + (cache if cache else
              "feedtune.tuner.cache has no solver_cache_info(); not reported"))
        if args.json:
            modes = {"single": single, **{f"batch, {w} worker(s)": runs[w] for w in workers},
                     **({f"batch, {last} worker(s), spawned": spawned} if spawned else {}),
                     "resumed": resumed,
                     **({f"batch, local Dask cluster of {last}": dask} if dask else {})}
            Path(args.json).write_text(json.dumps({
                "tree": str(TREE), "load": [load, load_after], "cache": cache,
                "modes": {label: {"specs_per_s": m["count"] / m["wall"],
                                  "cpu_ms": m["cpu"] / m["count"] * 1e3,
                                  "statuses": dict(m["statuses"])}
                          for label, m in modes.items()}}))
        if args.keep:
            print(f"kept: {root}")
    finally:
        if not args.keep:
            shutil.rmtree(root, ignore_errors=True)
    return 0


#: result fields that differ between any two runs (clocks, versions): not compared
_UNCOMPARED = {"solve_time", "build_time", "evaluation_time", "time", "provenance"}


def _leaves(value, path: str = ""):
    """(path, leaf) of every number, string, bool and null in a result's JSON, list indices
    kept, the run-dependent fields (:data:`_UNCOMPARED`) left out."""
    if isinstance(value, dict):
        for key, item in value.items():
            if key not in _UNCOMPARED:
                yield from _leaves(item, f"{path}/{key}")
    elif isinstance(value, list):
        for index, item in enumerate(value):
            yield from _leaves(item, f"{path}/{index}")
    else:
        yield path, value


def compare_results(old_dir: Path, new_dir: Path) -> str:
    """How the result files of two batch runs on the same specs differ: files equal in every
    compared field, every non-numeric difference, and per field (list indices and the
    metric names kept) the largest relative difference of its numbers,
    |a − b| / max(|a|, |b|), with the absolute one beside it for values near 0."""
    import re

    names = sorted(p.name for p in old_dir.glob("*.json") if p.name != "summary.json")
    equal, other, worst = 0, [], {}
    for name in names:
        new_path = new_dir / name
        if not new_path.exists():
            other.append(f"{name}: no result in the current run")
            continue
        old = dict(_leaves(json.loads((old_dir / name).read_text())))
        new = dict(_leaves(json.loads(new_path.read_text())))
        same = old.keys() == new.keys()
        if not same:
            other.append(f"{name}: fields differ: {sorted(old.keys() ^ new.keys())[:4]}")
        for path in old.keys() & new.keys():
            a, b = old[path], new[path]
            if a == b:
                continue
            same = False
            numbers = all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in (a, b))
            if not numbers:
                other.append(f"{name}{path}: {a!r} → {b!r}")
                continue
            field = re.sub(r"/\d+(?=/|$)", "/#", path)
            absolute = abs(a - b)
            relative = absolute / max(abs(a), abs(b))
            kept = worst.get(field, (0.0, 0.0, ""))
            worst[field] = (max(kept[0], relative), max(kept[1], absolute),
                            name if relative >= kept[0] else kept[2])
        equal += same
    lines = [f"results compared (run 1 of each, {len(names)} specs; clocks and provenance "
             f"aside): {equal} equal in every field, {len(names) - equal} not"]
    lines += [f"  {line}" for line in other[:20]]
    if len(other) > 20:
        lines.append(f"  ... {len(other) - 20} more non-numeric differences")
    if worst:
        lines.append("| field | largest relative difference | largest absolute | in |")
        lines.append("|---|---|---|---|")
        for field, (relative, absolute, name) in sorted(worst.items(), key=lambda kv: -kv[1][0]):
            lines.append(f"| {field} | {relative:.2e} | {absolute:.2e} | {name} |")
    return "\n".join(lines)


def compare(args, argv: list[str]) -> int:
    """Run the benchmark on ``args.baseline``'s tree and on this one, alternately, and
    print the ratios per mode (see the module docstring)."""
    import subprocess

    forwarded, skip = [], False
    for arg in argv:  # everything but --baseline/--rounds and their values
        if skip:
            skip = False
        elif arg in ("--baseline", "--rounds"):
            skip = True
        elif not arg.startswith(("--baseline=", "--rounds=")):
            forwarded.append(arg)
    root = Path(tempfile.mkdtemp(prefix="feedtune-batch-baseline-"))
    try:
        export_package(args.baseline, root)
        revision, current = short_revision(args.baseline), short_revision("HEAD")
        pairs = []
        for round_ in range(args.rounds):
            pair = []
            for tree in (root, REPO):
                out = root / f"run-{round_}-{'baseline' if tree == root else 'current'}.json"
                # PYTHONPATH too: a fresh interpreter started below (a Dask cluster's
                # forkserver, which imports feedtune before any worker tells it sys.path)
                # must load the same tree
                env = {**os.environ, "FEEDTUNE_BENCH_TREE": str(tree),
                       "PYTHONPATH": os.pathsep.join(
                           [str(tree), *filter(None, [os.environ.get("PYTHONPATH")])])}
                results = root / f"results-{round_}-{'baseline' if tree == root else 'current'}"
                subprocess.run([sys.executable, __file__, *forwarded, "--json", str(out),
                                "--results", str(results)], check=True, env=env)
                pair.append(json.loads(out.read_text()))
            pairs.append(pair)
        print()
        print(f"baseline {args.baseline} ({revision}) against this checkout ({current}, "
              "uncommitted changes included), current/baseline:")
        print()
        print("| round | mode | baseline specs/s | current specs/s | ratio | baseline CPU ms/spec "
              "| current CPU ms/spec | CPU ratio | load (baseline, current) |")
        print("|---|---|---|---|---|---|---|---|---|")
        for round_, (old, new) in enumerate(pairs, start=1):
            for label, a in old["modes"].items():
                b = new["modes"][label]
                print(f"| {round_} | {label} | {a['specs_per_s']:.1f} | {b['specs_per_s']:.1f} | "
                      f"{b['specs_per_s'] / a['specs_per_s']:.2f} | {a['cpu_ms']:.1f} | "
                      f"{b['cpu_ms']:.1f} | {a['cpu_ms'] / b['cpu_ms']:.2f} | "
                      f"{old['load'][0]:.1f}–{old['load'][1]:.1f}, "
                      f"{new['load'][0]:.1f}–{new['load'][1]:.1f} |")
        for name, run in (("baseline", pairs[-1][0]), ("current", pairs[-1][1])):
            print(f"solver cache, single solves, {name}: {run['cache']}")
        print()
        print(compare_results(root / "results-0-baseline", root / "results-0-current"))
    finally:
        shutil.rmtree(root, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
