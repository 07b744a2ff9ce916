"""Loops of numbers of every linear plant configuration, built point by point as a robust
search, a batch's reports or the plant contract's stability test builds them: this
checkout's ``feedtune`` against a git revision's, in child processes run in turn
(issue 15).

For every configuration of the contract tests (``tests/contract/contract_cases.py``) and
every ``--stride``-th point of its stability sample (the default grid and, for plants with
compensators, seeded random points): the loop of numbers, its stability matrices as
arrays, its characteristic polynomial and its stability conditions as floats. Prints the
CPU of each tree per round (the same points in each), the ratio, and how many of the
numbers are the same bits (and the largest difference relative to max(|value|, 1)).

    .venv/bin/python benchmarks/contract_loops_of_numbers.py [--baseline main] [--rounds 2]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from baseline import export_package, short_revision

REPO = Path(__file__).resolve().parents[1]

CHILD = r"""
import json, sys, time
sys.path.insert(0, {contract!r})
from feedtune.__main__ import pin_blas_threads
pin_blas_threads()
import contract_cases as cc

values = []
start = time.process_time()
for config in cc.CONFIGS:
    plant = config.plant
    for point in cc.stability_sample(config)[::{stride}]:
        loop = plant.loop(point, config.default_box)
        for matrix in loop.stability_matrices().values():
            values += cc.as_array(matrix).ravel().tolist()
        values += [float(cc.as_array(c)[0, 0]) for c in loop.characteristic_polynomial]
        values += [float(cc.as_array(c)[0, 0]) for c in loop.stability_conditions()]
print(json.dumps({{"cpu": time.process_time() - start, "values": values}}))
"""


def _run(tree: Path, stride: int) -> dict:
    env = {**os.environ, "PYTHONPATH": str(tree)}
    code = CHILD.format(contract=str(REPO / "tests" / "contract"), stride=stride)
    out = subprocess.run([sys.executable, "-c", code], env=env, cwd=tempfile.gettempdir(),
                         capture_output=True, text=True, check=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", default="main", help="git revision of the old package")
    parser.add_argument("--rounds", type=int, default=2, help="alternating rounds")
    parser.add_argument("--stride", type=int, default=2, help="every stride-th point")
    args = parser.parse_args()
    old_tree = export_package(args.baseline, Path(tempfile.mkdtemp(prefix="feedtune-baseline-")))
    trees = {short_revision(args.baseline): old_tree, "new": REPO}
    cpu = {label: [] for label in trees}
    worst, same = 0.0, 0
    for _ in range(args.rounds):
        results = {label: _run(tree, args.stride) for label, tree in trees.items()}
        for label, result in results.items():
            cpu[label].append(result["cpu"])
        old, new = (results[label]["values"] for label in trees)
        assert len(old) == len(new)
        worst = max(worst, max(abs(a - b) / max(abs(a), 1.0) for a, b in zip(old, new)))
        same = sum(a == b or (a != a and b != b) for a, b in zip(old, new))
    (old_label, old_cpu), (_, new_cpu) = cpu.items()
    print(f"{len(old)} numbers per round; CPU s per round: {old_label} "
          f"{', '.join(f'{c:.2f}' for c in old_cpu)}; new {', '.join(f'{c:.2f}' for c in new_cpu)}")
    print(f"new/{old_label} {sum(new_cpu) / sum(old_cpu):.3f}; largest difference {worst:.1e}; "
          f"{same} of {len(old)} the same bits")


if __name__ == "__main__":
    main()
