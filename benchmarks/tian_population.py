"""Tian's search: scipy's Latin-hypercube initial population against the Sobol one it had.

Differential evolution (``feedtune/tuner/search.py``) started from a scrambled Sobol
population until issue 15's last change: 32 members for three tunables, and an import of
``scipy.stats`` (0.25–0.5 s) in the process's first tuning. It now starts from scipy's
default Latin hypercube: 24 members, no ``scipy.stats``. This script tunes random variants
of ``examples/tian-vf-pulse.json`` (seeded: step 1, 3, 10 or 20 rad; motor 84–196 krad/s²
at rest falling to 50–100 % of it at 140 kHz; δ ±20 %; k's upper bound 2 000, 5 000 or
10 000; value's lower bound 0.01, 0.05 or 0.2 rad) with each population in turn, in one
process, and prints per variant each side's settling time (the objective), whether the
result validated, the time per tuning, and the relative difference; then the mean
difference and how many variants each side won by more than 1 %.

A single start of differential evolution is a random search: its result moves between
seeds by more than the populations' difference, so read the counts, not one variant.

Run: ``.venv/bin/python benchmarks/tian_population.py [--variants 30] [--seed 2]``
"""

from __future__ import annotations

import argparse
import copy
import json
import os
import random
import statistics
import time
from pathlib import Path

for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import feedtune.tuner.search as search  # noqa: E402
from feedtune.problem import tune  # noqa: E402
from feedtune.schema.spec import parse_spec  # noqa: E402

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "tian-vf-pulse.json"
SIDES = ("latinhypercube", "sobol")  # this tree's, the one before


def variant(raw: dict, rng: random.Random) -> dict:
    spec = copy.deepcopy(raw)
    spec["plant"]["amplitude"] = rng.choice([1, 3, 10, 20])
    rest = 140e3 * rng.uniform(0.6, 1.4)
    spec["plant"]["motor_characteristic"] = [[0, rest], [140e3, rest * rng.uniform(0.5, 1.0)]]
    spec["plant"]["pulse_equivalent"] *= rng.uniform(0.8, 1.2)
    spec["tunables"]["acceleration_ratio"]["max"] = rng.choice([2000, 5000, 10000])
    spec["tunables"]["error_limit"]["min"] = rng.choice([0.01, 0.05, 0.2])
    return spec


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--variants", type=int, default=30, help="random specs [count]")
    parser.add_argument("--seed", type=int, default=2, help="seed of the variants")
    args = parser.parse_args()
    import scipy.stats  # noqa: F401  (the Sobol side's; imported before any clock starts)

    raw = json.loads(EXAMPLE.read_text())
    rng = random.Random(args.seed)
    print(f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    print(f"{'variant':>7} " + " ".join(f"{side:>30}" for side in SIDES) + "   LHS/Sobol - 1")
    gaps, times = [], {side: [] for side in SIDES}
    for index in range(args.variants):
        spec = parse_spec(variant(raw, rng))
        cells, values = [], []
        for side in SIDES:
            search.INITIAL_POPULATION = side
            begun = time.perf_counter()
            result = tune(spec)
            elapsed = time.perf_counter() - begun
            value = result.metrics["pulse_settling_time"].value
            valid = result.success and result.validation["ok"]
            verdict = "valid" if valid else "NOT valid"
            cells.append(f"{value * 1e3:9.4f} ms {verdict:>9} {elapsed:5.2f} s")
            values.append(value)
            times[side].append(elapsed)
        gaps.append(values[0] / values[1] - 1.0)
        print(f"{index:>7} " + " ".join(f"{c:>30}" for c in cells) + f"   {gaps[-1]:+.4f}")
    search.INITIAL_POPULATION = SIDES[0]
    worse = sum(g > 0.01 for g in gaps)
    better = sum(g < -0.01 for g in gaps)
    print(f"\nmean LHS/Sobol - 1: {statistics.mean(gaps):+.4f}; LHS worse by > 1 %: {worse}, "
          f"better by > 1 %: {better}, of {len(gaps)}")
    print("mean time per tuning: " + ", ".join(f"{side} {statistics.mean(t):.3f} s"
                                               for side, t in times.items()))
    print(f"load average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
