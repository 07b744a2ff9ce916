"""The robust tunings of the reference tests, this checkout's ``feedtune/robust.py`` against
a baseline revision's, side by side in one process (issue 15's test-time work).

The specs are the robust ones of tests/reference/test_robust_plants.py and
test_robust_tuning.py, taken from those modules: Ward-Leonard with J_t ± 50 %, the
user-defined linear drive with θ and one denominator coefficient uncertain, Tian's pulse
generator with δ ± 20 %, Bhatia's ``bhatia-1971-robust-inertia`` example, Koren's software
servo with τ in 10–20 ms (reference pulse and sampled data) and his sampled servo with a
bandwidth bound over τ in 5–40 ms (a worst case between the corners). Each is tuned by
both modules in turn, the baseline's module loaded beside this one by
``benchmarks/baseline.py`` (everything else it imports is this checkout's), alternating
which goes first, ``--repeat`` times; the tuner's solver and structure caches stay warm
after a first untimed tuning of each spec, so both sides time the same work. Printed per
spec: the median CPU time [s] (``time.process_time``) of each side, new/old, the rounds,
and whether the two results are equal (every field but the solver's clocks; else the
first paths that differ).

Run: ``.venv/bin/python benchmarks/robust_rounds_speed.py [--baseline main] [--repeat 3]``
"""

from __future__ import annotations

import argparse
import copy
import os
import statistics
import sys
import time
from pathlib import Path

from feedtune.__main__ import pin_blas_threads

pin_blas_threads()  # one BLAS thread, as the command and the test suite run (before numpy)
sys.path.insert(0, str(Path(__file__).resolve().parent))
from baseline import baseline_module  # noqa: E402

from feedtune.problem import tune  # noqa: E402
import feedtune.robust as new_robust  # noqa: E402
from feedtune.schema.spec import parse_spec  # noqa: E402

TESTS = Path(__file__).resolve().parents[1] / "tests" / "reference"


def specs() -> dict[str, dict]:
    """The robust specs of the reference tests, by a short name, taken from the test
    modules themselves (tests/reference on the path, as pytest's rootdir conftest puts it)."""
    sys.path.insert(0, str(TESTS))
    import test_robust_plants as plants
    import test_robust_tuning as tuning

    return {"ward-leonard": plants._ward_leonard(True), "linear": plants._linear(True),
            "tian": plants._tian(True),
            "bhatia": plants.load_example("bhatia-1971-robust-inertia"),
            "servo-reference_pulse": tuning._servo("reference_pulse", 0.7, True),
            "servo-sampled_data": tuning._servo("sampled_data", 0.7, True),
            "koren-bandwidth": copy.deepcopy(tuning.BANDWIDTH)}


def _comparable(result) -> dict:
    data = result.model_dump(mode="json")
    for clock in ("solve_time", "build_time", "evaluation_time"):
        data["solver"].pop(clock, None)
    for start in data["solver"].get("starts") or []:
        for clock in ("solve_time", "time"):
            start.pop(clock, None)
    return data


def _differences(x, y, path: str = "") -> list[str]:
    """The paths at which two results' dicts differ."""
    if isinstance(x, dict) and isinstance(y, dict):
        return [d for k in sorted(set(x) | set(y), key=str)
                for d in _differences(x.get(k), y.get(k), f"{path}/{k}")]
    if isinstance(x, list) and isinstance(y, list) and len(x) == len(y):
        return [d for i, (p, q) in enumerate(zip(x, y)) for d in _differences(p, q, f"{path}/{i}")]
    return [] if x == y else [path]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", default="main", help="git revision of the old robust.py")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--only", nargs="*", help="spec names (default: all)")
    args = parser.parse_args()
    old_robust = baseline_module(args.baseline, "feedtune/robust.py", "baseline_robust")
    sides = {"new": new_robust.tune_robust, "old": old_robust.tune_robust}
    print(f"load before {os.getloadavg()}")
    print(f"{'spec':24} {'old s':>8} {'new s':>8} {'new/old':>8} {'rounds':>6}  equal")
    total = {"new": 0.0, "old": 0.0}
    for name, data in specs().items():
        if args.only and name not in args.only:
            continue
        spec = parse_spec(copy.deepcopy(data))
        tune(spec)  # warm: solvers and structures built once for both sides
        times = {"new": [], "old": []}
        results = {}
        for k in range(args.repeat):
            for side in (("new", "old") if k % 2 == 0 else ("old", "new")):
                tick = time.process_time()
                results[side] = sides[side](spec)
                times[side].append(time.process_time() - tick)
        old, new = statistics.median(times["old"]), statistics.median(times["new"])
        total["old"] += old
        total["new"] += new
        differences = _differences(_comparable(results["new"]), _comparable(results["old"]))
        print(f"{name:24} {old:8.3f} {new:8.3f} {new / old:8.3f} "
              f"{results['new'].robust.rounds:6d}  {not differences} {' '.join(differences[:4])}")
    print(f"{'all':24} {total['old']:8.3f} {total['new']:8.3f} "
          f"{total['new'] / total['old']:8.3f}")
    print(f"load after {os.getloadavg()}")


if __name__ == "__main__":
    main()
