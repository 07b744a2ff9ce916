#!/usr/bin/env python
"""The validator on batch results: where its CPU goes per check, and this checkout's
against a git revision's, every entry compared (issue 15's batch target).

The first ``--specs`` specs of ``benchmarks/batch_throughput.py``'s generated set are tuned
once with this checkout (``feedtune.batch.job.solve``; the results kept in ``--results``,
made when missing), then only the validation is replayed on them, the way a batch worker
runs it (``feedtune.problem._validation``), in one process with one BLAS thread.

``--checks``: this checkout's CPU a spec per check: the model's construction, each
metric's measurement (a measurement pays for the model parts it is the first to need, as
in a real run), the judging, the pole and stability rows; ``--in-batch`` times them while
``job.solve`` tunes the specs (as ``batch_profile.py``), not on the replayed results.

``--baseline REV``: each tree (REV's ``feedtune/`` by ``git archive``, and this checkout)
validates every result in a child process of its own, ``--rounds`` times in turn; printed:
the CPU a spec of each round, the ratio, and every entry of every block compared (the
validated value, gap and tolerance to the bit, the basis and the verdict).

    .venv/bin/python benchmarks/validator_batch.py --specs 120 --checks
    .venv/bin/python benchmarks/validator_batch.py --specs 300 --baseline main --rounds 3
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from collections import Counter, defaultdict
from pathlib import Path

for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

REPO = Path(__file__).resolve().parents[1]

#: a child: validate every result in ``results`` (one JSON a line) ``rounds`` times; print
#: one JSON line {"cpu": [s a round], "blocks": [the last round's blocks]}
CHILD = r"""
import json, sys, time
from feedtune.__main__ import pin_blas_threads
pin_blas_threads()
from feedtune.problem import _validation
from feedtune.schema.result import TuneResult
results = [TuneResult.model_validate_json(line) for line in open(sys.argv[1]).read().splitlines()]
for r in results[:5]:  # imports and first calls
    _validation(r)
cpu = []
for _ in range(int(sys.argv[2])):
    started = time.process_time()
    blocks = [_validation(r) for r in results]
    cpu.append(time.process_time() - started)
print(json.dumps({"cpu": cpu, "blocks": blocks}))
"""


def ensure_results(path: Path, count: int) -> Path:
    """``path`` holding results (one JSON a line): as it is when it exists, else the first
    ``count`` generated specs' results, tuned with this checkout."""
    if path.exists():
        return path
    sys.path.insert(0, str(REPO))
    sys.path.insert(1, str(REPO / "benchmarks"))
    from batch_throughput import generate

    import feedtune.batch.job as job

    lines = []
    for spec in generate(max(count, 300))[:count]:
        outcome = job.solve(json.dumps(spec).encode())
        lines.append(json.dumps(json.loads(outcome.result)))
    path.write_text("\n".join(lines) + "\n")
    return path


def _head(path: Path, count: int) -> Path:
    """The first ``count`` lines of ``path`` in a temporary file."""
    out = Path(tempfile.mkdtemp()) / "results.jsonl"
    out.write_text("\n".join(path.read_text().splitlines()[:count]) + "\n")
    return out


def checks(path: Path, rounds: int, in_batch: bool) -> None:
    """Print this checkout's CPU a spec per check (see the module's docstring); with
    ``in_batch`` while the specs are tuned (``job.solve``), not replayed."""
    sys.path.insert(0, str(REPO))
    sys.path.insert(1, str(REPO / "benchmarks"))
    from feedtune.__main__ import pin_blas_threads

    pin_blas_threads()
    import feedtune.batch.job as job
    import feedtune.problem as problem
    import feedtune.validate.block as block
    import feedtune.validate.measurements as measurements
    import feedtune.validate.tolerances as tolerances
    from feedtune.schema.result import TuneResult

    results = [TuneResult.model_validate_json(line) for line in path.read_text().splitlines()]
    totals: dict[str, float] = defaultdict(float)

    def timed(label, fn):
        def wrapper(*args, **kwargs):
            started = time.process_time()
            try:
                return fn(*args, **kwargs)
            finally:
                totals[label] += time.process_time() - started
        return wrapper

    seen = set()
    for module in [m for name, m in sys.modules.items() if name.startswith("feedtune.validate")]:
        for attr in ("SERVO_MEASUREMENTS", "MEASUREMENTS", "REFERENCE_PULSE_FREQUENCY",
                     "POLE_MEASUREMENTS", "PAIR_MEASUREMENTS"):
            table = getattr(module, attr, None)
            if not isinstance(table, dict) or id(table) in seen:
                continue
            seen.add(id(table))
            for name, row in list(table.items()):
                table[name] = measurements.Measurement(timed(f"measure {name}", row.measure),
                                                       row.covers)
    block.model_for = timed("model construction", block.model_for)
    measurements.judge = timed("judge (tolerances)", tolerances.judge)
    block.poles_entry = timed("poles row", block.poles_entry)
    block.stable_entry = timed("stable row", block.stable_entry)
    block.validate_result = timed("validate_result", block.validate_result)
    TuneResult.model_dump = timed("TuneResult.model_dump (validate_result's and others')",
                                  TuneResult.model_dump)
    from feedtune.validate.software_servo import ServoModel

    ServoModel.context = timed("ServoModel.context (time scale)", ServoModel.context)
    import feedtune.validate as validate_package

    validate_package.validate_result = block.validate_result
    problem._validation = timed("_validation (all of it)", problem._validation)
    if in_batch:
        from batch_throughput import generate, one_spec_per_structure

        specs = generate(max(len(results), 300))
        for spec in one_spec_per_structure(specs):  # imports, first calls
            job.solve(json.dumps(spec).encode())
        data = [json.dumps(spec).encode() for spec in specs[:len(results)]]
        totals.clear()
        for _ in range(rounds):
            for d in data:
                job.solve(d)
    else:
        for r in results[:5]:
            problem._validation(r)
        totals.clear()
        for _ in range(rounds):
            for r in results:
                problem._validation(r)
    n = len(results) * rounds
    how = "tuned by job.solve" if in_batch else "validation replayed"
    print(f"{len(results)} specs × {rounds} rounds ({how}), feedtune from {REPO}; load "
          f"average {os.getloadavg()[0]:.2f}")
    print()
    print("| check | CPU ms a spec |")
    print("|---|---|")
    for label, value in sorted(totals.items(), key=lambda kv: -kv[1]):
        print(f"| {label} | {value / n * 1e3:.3f} |")


def _leaves(entry: dict) -> dict:
    return {key: entry.get(key) for key in ("metric", "options", "reported", "validated", "gap",
                                              "tolerance", "basis", "ok")}


def compare(old: list[dict], new: list[dict]) -> list[str]:
    """Lines describing every difference between two lists of blocks."""
    lines, worst, moved = [], defaultdict(float), Counter()
    entries = same = 0
    for i, (a, b) in enumerate(zip(old, new)):
        for key in ("covered", "ok", "reason", "error"):
            if a.get(key) != b.get(key):
                lines.append(f"result {i}: block {key} {a.get(key)!r} → {b.get(key)!r}")
        ea, eb = a.get("entries") or [], b.get("entries") or []
        if len(ea) != len(eb):
            lines.append(f"result {i}: {len(ea)} → {len(eb)} entries")
            continue
        for x, y in zip(ea, eb):
            entries += 1
            x, y = _leaves(x), _leaves(y)
            if x == y:
                same += 1
                continue
            moved[x["metric"]] += 1
            for key in x:
                if x[key] == y[key]:
                    continue
                if key in ("validated", "tolerance") and isinstance(x[key], float):
                    rel = abs(x[key] - y[key]) / abs(x[key])
                    worst[(x["metric"], f"{key} (relative)")] = max(
                        worst[(x["metric"], f"{key} (relative)")], rel)
                elif key == "gap" and isinstance(x[key], float):  # a gap is often 0
                    rel = abs(x[key] - y[key]) / x["tolerance"]
                    worst[(x["metric"], "gap (of the tolerance)")] = max(
                        worst[(x["metric"], "gap (of the tolerance)")], rel)
                else:
                    lines.append(f"result {i} {x['metric']}: {key} {x[key]!r} → {y[key]!r}")
    lines.insert(0, f"{entries} entries in {len(old)} blocks: {same} equal in every field; "
                    f"the others: {dict(moved) if moved else 'none'}")
    for (metric, key), rel in sorted(worst.items()):
        lines.append(f"  {metric} {key}: largest difference {rel:.2e}")
    return lines


def side_by_side(path: Path, revision: str, rounds: int) -> None:
    """Both trees' validation of every result, ``rounds`` times in turn."""
    sys.path.insert(0, str(REPO / "benchmarks"))
    from baseline import export_package, short_revision

    base = export_package(revision, Path(tempfile.mkdtemp()))
    trees = {short_revision(revision): base, "this checkout": REPO}
    cpu: dict[str, list[float]] = defaultdict(list)
    blocks = {}
    count = len(path.read_text().splitlines())
    print(f"{count} results from {path}; load average {os.getloadavg()[0]:.2f} at start")
    for _ in range(rounds):
        for label, tree in trees.items():
            env = {**os.environ, "PYTHONPATH": str(tree)}
            out = subprocess.run([sys.executable, "-c", CHILD, str(path), "1"], env=env,
                                 check=True, capture_output=True, text=True, cwd=tree).stdout
            data = json.loads(out.splitlines()[-1])
            cpu[label] += data["cpu"]
            blocks[label] = data["blocks"]
    (old_label, old_cpu), (new_label, new_cpu) = cpu.items()
    print(f"CPU ms a spec per round: {old_label} "
          f"{', '.join(f'{c / count * 1e3:.2f}' for c in old_cpu)}; {new_label} "
          f"{', '.join(f'{c / count * 1e3:.2f}' for c in new_cpu)}; "
          f"ratio {sum(new_cpu) / sum(old_cpu):.3f}; load average {os.getloadavg()[0]:.2f} "
          f"at end")
    for line in compare(blocks[old_label], blocks[new_label]):
        print(line)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--specs", type=int, default=120)
    parser.add_argument("--results", type=Path,
                        default=Path(tempfile.gettempdir()) / "feedtune-validator-batch.jsonl")
    parser.add_argument("--checks", action="store_true")
    parser.add_argument("--in-batch", action="store_true",
                        help="--checks while job.solve tunes the specs, not on replayed results")
    parser.add_argument("--baseline")
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args(argv)
    path = _head(ensure_results(args.results, args.specs), args.specs)
    if args.checks:
        checks(path, args.rounds, args.in_batch)
    if args.baseline:
        side_by_side(path, args.baseline, args.rounds)
    return 0


if __name__ == "__main__":
    sys.exit(main())
