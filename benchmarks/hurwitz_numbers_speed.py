"""Hurwitz conditions of numbers (issue 15's test time, h-tref3): the operations written out
on numbers (main's path for a loop of numbers) against the cached SX Function evaluated
(``linalg.hurwitz_conditions`` now), on the coefficient lists the robust worst-case search
really meets, side by side in one process.

The coefficient lists are recorded while this checkout tunes the user-defined linear drive
robustly (θ 0.1-0.4 ms, a₂ ± 30 %: tests/reference/test_robust_plants.py) and the README's
Ward-Leonard drive with J_t ± 50 %: every ``hurwitz_conditions`` call on numbers (the
search's :class:`feedtune.robust.PointCheck`, the tuner's exact evaluation). Then each list
is evaluated both ways ``--repeat`` times, interleaved; printed: CPU per side (the fastest
round), the ratio, and how many lists gave the same bits in every condition.

Run: ``.venv/bin/python benchmarks/hurwitz_numbers_speed.py [--repeat N]``
"""

from __future__ import annotations

import argparse
import copy
import json
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def _specs() -> list[dict]:
    linear = json.loads((REPO / "examples" / "user-defined-drive.json").read_text())
    linear["plant"]["dead_time"] = {"min": 1e-4, "max": 4e-4, "nominal": 2e-4}
    linear["plant"]["model"]["denominator"][2] = {"nominal": 6.0, "tolerance_percent": 30}
    linear["robust"] = {"interior_samples": 0}
    ward = json.loads((REPO / "examples" / "ward-leonard-feed-drive.json").read_text())
    ward["plant"].update(velocity_compensator="none", position_compensator="none",
                         inertia={"nominal": 10.0, "tolerance_percent": 50})
    ward["tunables"] = {"position_gain": {"min": 1, "max": 1000, "initial": 20},
                        "velocity_gain": {"min": 1, "max": 1000, "initial": 100}}
    ward["constraints"] = [{"metric": "m_peak", "max": 1.3}]
    return [linear, ward]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()

    from feedtune.__main__ import pin_blas_threads

    pin_blas_threads()
    import casadi as ca

    from feedtune.loops import linalg
    from feedtune.problem import tune
    from feedtune.schema.spec import parse_spec

    recorded = []
    original = linalg.hurwitz_conditions

    def record(coefficients):
        if not any(isinstance(c, (ca.MX, ca.SX)) for c in coefficients):
            recorded.append(list(coefficients))
        return original(coefficients)

    linalg.hurwitz_conditions = record
    try:
        for spec in _specs():
            tune(parse_spec(copy.deepcopy(spec)))
    finally:
        linalg.hurwitz_conditions = original

    sides = {"written out (main)": linalg._hurwitz_conditions,
             "Function (new)": linalg.hurwitz_conditions}
    times = {name: [] for name in sides}
    values = {}
    for _ in range(args.repeat):
        for name, fn in sides.items():
            tick = time.process_time()
            values[name] = [fn(c) for c in recorded]
            times[name].append(time.process_time() - tick)
    old, new = (min(times[name]) for name in sides)
    same = sum(len(a) == len(b) and all(float(x) == float(y) for x, y in zip(a, b))
               for a, b in zip(*values.values()))
    print(f"{len(recorded)} coefficient lists (degrees "
          f"{sorted({len(c) - 1 for c in recorded})}), fastest of {args.repeat} rounds, CPU:")
    print(f"  written out (main) {old:.3f} s ({1e3 * old / len(recorded):.3f} ms a list)")
    print(f"  Function (new)     {new:.3f} s ({1e3 * new / len(recorded):.3f} ms a list)")
    print(f"  new/old {new / old:.2f}; the same bits in every condition: {same} of {len(recorded)}")


if __name__ == "__main__":
    main()
