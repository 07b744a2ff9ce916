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

from baseline import numbers_side_by_side

CHILD = r"""
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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", default="main", help="git revision of the old package")
    parser.add_argument("--rounds", type=int, default=2, help="alternating rounds")
    parser.add_argument("--stride", type=int, default=2, help="every stride-th point")
    args = parser.parse_args()
    numbers_side_by_side(CHILD, args.baseline, args.rounds, stride=args.stride)


if __name__ == "__main__":
    main()
