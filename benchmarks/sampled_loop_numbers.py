"""Loops of numbers of the sampled LTI loop, built point by point as a robust search, a
batch or the plant contract builds them: this checkout's ``feedtune`` against a git
revision's, in child processes run in turn (issue 15).

For every ``implementation: sampled`` configuration of the contract tests
(``tests/contract/contract_cases.py``) and every ``--stride``-th point of its default grid:
the loop of numbers, its stability matrices as arrays, and its closed-loop, error and
open-loop responses at three frequencies and its C_v, each evaluated to numbers. Prints
the CPU of each tree per round (the same points in each), the ratio, and whether the two
trees' numbers agree (largest difference relative to max(|value|, 1)).

    .venv/bin/python benchmarks/sampled_loop_numbers.py [--baseline main] [--rounds 2]
"""

from __future__ import annotations

import argparse

from baseline import numbers_side_by_side

CHILD = r"""
values = []
start = time.process_time()
for config in cc.CONFIGS:
    if "implementation=sampled" not in config.id:
        continue
    plant = config.plant
    for point in cc.grid(config)[::{stride}]:
        loop = plant.loop(point, config.default_box)
        for matrix in loop.stability_matrices().values():
            values += cc.as_array(matrix).ravel().tolist()
        if {full}:  # what the plant contract also reads
            values += cc.as_array(loop.input_matrix).ravel().tolist()
            values += [float(cc.as_array(c)[0, 0]) for c in loop.characteristic_polynomial]
            values += [float(cc.as_array(c)[0, 0]) for c in loop.stability_conditions()]
            for matrix in loop.open_loop_matrices:
                values += cc.as_array(matrix).ravel().tolist()
            values.append(float(cc.as_array(loop.dc_gain())[0, 0]))
        for omega in (0.3, 3.0, 30.0):
            for response in (loop.frequency_response, loop.error_response,
                             loop.open_loop_response) + ((loop.sensitivity_response,) if {full} else ()):
                values += [float(cc.as_array(part)[0, 0]) for part in response(omega)]
        values.append(float(cc.as_array(loop.velocity_constant)[0, 0]))
print(json.dumps({{"cpu": time.process_time() - start, "values": values}}))
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", default="main", help="git revision of the old package")
    parser.add_argument("--rounds", type=int, default=2, help="alternating rounds")
    parser.add_argument("--stride", type=int, default=3, help="every stride-th grid point")
    parser.add_argument("--full", action="store_true",
                        help="also the input matrix, the characteristic polynomial, the "
                             "stability conditions, the open loop's matrices, H(1) and S")
    args = parser.parse_args()
    numbers_side_by_side(CHILD, args.baseline, args.rounds, stride=args.stride, full=args.full)


if __name__ == "__main__":
    main()
