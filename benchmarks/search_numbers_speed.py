"""Two helpers of loops of numbers (issue 15's test time, h-tref3), main's against this
checkout's, side by side in one process, on the arguments a robust tuning really passes:

* the Hurwitz conditions of numbers: the operations written out on DM numbers (main's path)
  against the cached SX Function evaluated (``linalg.hurwitz_conditions`` now);
* ``expr.to_float``: main's (every number through a DM and a numpy array) against this
  one (a float or a 1 × 1 DM read directly).

The arguments are recorded while this checkout tunes the user-defined linear drive
robustly (θ 0.1-0.4 ms, a₂ ± 30 %: tests/reference/test_robust_plants.py) and the README's
Ward-Leonard drive with J_t ± 50 %: every ``hurwitz_conditions`` call on numbers and every
``to_float`` call (the search's :class:`feedtune.robust.PointCheck`, the tuner's exact
evaluation). Then each is evaluated both ways ``--repeat`` times, interleaved; printed:
CPU per side (the fastest round), the ratio, and how many gave the same bits.

Run: ``.venv/bin/python benchmarks/search_numbers_speed.py [--repeat N]``
"""

from __future__ import annotations

import argparse
import copy
import json
import sys
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

    from feedtune import expr
    from feedtune.loops import linalg
    from feedtune.problem import tune
    from feedtune.schema.spec import parse_spec

    recorded, floats = [], []
    original, original_float = linalg.hurwitz_conditions, expr.to_float

    def record(coefficients):
        if not any(isinstance(c, (ca.MX, ca.SX)) for c in coefficients):
            recorded.append(list(coefficients))
        return original(coefficients)

    def record_float(value):
        floats.append(value)
        return original_float(value)

    linalg.hurwitz_conditions = record
    expr.to_float = record_float
    modules = [m for m in list(sys.modules.values())
               if getattr(m, "to_float", None) is original_float]
    for module in modules:
        module.to_float = record_float
    try:
        for spec in _specs():
            tune(parse_spec(copy.deepcopy(spec)))
    finally:
        linalg.hurwitz_conditions = original
        for module in modules + [expr]:
            module.to_float = original_float

    def main_to_float(value) -> float:  # main's (a006aa6)
        return float(expr.to_array(value).reshape(-1)[0])

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

    times = {"main": [], "new": []}
    for _ in range(args.repeat):
        for name, fn in (("main", main_to_float), ("new", expr.to_float)):
            tick = time.process_time()
            values[name] = [fn(v) for v in floats]
            times[name].append(time.process_time() - tick)
    old, new = min(times["main"]), min(times["new"])
    same = sum(a == b or (a != a and b != b) for a, b in zip(values["main"], values["new"]))
    kinds = sorted({type(v).__name__ for v in floats})
    print(f"to_float: {len(floats)} calls ({', '.join(kinds)}): main {old:.3f} s, new {new:.3f} s, "
          f"new/old {new / old:.2f}; the same number: {same} of {len(floats)}")


if __name__ == "__main__":
    main()
