"""The robust tunings of the reference tests, this checkout's ``feedtune/robust.py`` against
a baseline revision's, side by side in one process (issue 15's test-time work).

The specs are those of tests/reference/test_robust_plants.py and test_robust_tuning.py:
Ward-Leonard with J_t ± 50 %, the user-defined linear drive with θ and one denominator
coefficient uncertain, Tian's pulse generator with δ ± 20 %, Bhatia's
``bhatia-1971-robust-inertia`` example, and Koren's software servo with τ in 10–20 ms
(reference pulse and sampled data) and Koren's sampled servo with a bandwidth bound over
τ in 5–40 ms (the worst case between the corners). Each is tuned by both modules in turn, the baseline's
module loaded beside this one by ``benchmarks/baseline.py`` (everything else it imports is
this checkout's), alternating which goes first, ``--repeat`` times; the tuner's solver and
structure caches stay warm after a first untimed tuning of each spec, so both sides time
the same work. Printed per spec: the median CPU time [s] (``time.process_time``) of each
side, new/old, the rounds, and whether the two results are equal (every field but the
solver's clocks).

Run: ``.venv/bin/python benchmarks/robust_rounds_speed.py [--baseline main] [--repeat 3]``
"""

from __future__ import annotations

import argparse
import copy
import json
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

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _example(name: str) -> dict:
    return json.loads((EXAMPLES / f"{name}.json").read_text())


def specs() -> dict[str, dict]:
    """The robust specs of the reference tests, by a short name."""
    wl = _example("ward-leonard-feed-drive")
    wl["plant"].update(velocity_compensator="none", position_compensator="none",
                       inertia={"nominal": 10.0, "tolerance_percent": 50})
    wl["tunables"] = {"position_gain": {"min": 1, "max": 1000, "initial": 20},
                      "velocity_gain": {"min": 1, "max": 1000, "initial": 100}}
    wl["constraints"] = [{"metric": "m_peak", "max": 1.3}]
    linear = _example("user-defined-drive")
    linear["plant"]["dead_time"] = {"min": 1e-4, "max": 4e-4, "nominal": 2e-4}
    linear["plant"]["model"]["denominator"][2] = {"nominal": 6.0, "tolerance_percent": 30}
    linear["robust"] = {"interior_samples": 0}
    tian = _example("tian-vf-pulse")
    tian["plant"]["pulse_equivalent"] = {"nominal": tian["plant"]["pulse_equivalent"],
                                         "tolerance_percent": 20}
    tian["robust"] = {"interior_samples": 0}
    out = {"ward-leonard": wl, "linear": linear, "tian": tian,
           "bhatia": _example("bhatia-1971-robust-inertia")}
    for technique in ("reference_pulse", "sampled_data"):  # test_robust_tuning's _servo
        tunables = {"position_gain": {"min": 1, "max": 200}}
        if technique == "sampled_data":
            tunables["sampling_period"] = {"value": 0.015625}
        out[f"servo-{technique}"] = {
            "name": f"koren-{technique}-robust",
            "plant": {"type": "software_servo", "technique": technique,
                      "time_constant": {"min": 0.010, "max": 0.020}, "blu": 5e-6,
                      "max_velocity": 0.04},
            "tunables": tunables,
            "objective": [{"metric": "radial_error", "radius": 0.008, "feed": 0.04}],
            "constraints": [{"metric": "damping_ratio", "min": 0.7}],
            "solver": {"multistart": 1}}
    bandwidth = {"name": "koren-bandwidth-robust",  # test_robust_tuning's BANDWIDTH
                 "plant": {"type": "software_servo", "technique": "sampled_data",
                           "time_constant": {"min": 0.005, "max": 0.040, "nominal": 0.03},
                           "blu": 5e-6, "max_velocity": 0.04},
                 "tunables": {"position_gain": {"min": 1, "max": 200},
                              "sampling_period": {"value": 0.015625}},
                 "objective": [{"metric": "velocity_constant", "goal": "maximize"}],
                 "constraints": [{"metric": "bandwidth", "max": 30}],
                 "robust": {"interior_samples": 0}, "solver": {"multistart": 1}}
    out["koren-bandwidth"] = bandwidth
    return out


def _comparable(result) -> dict:
    data = result.model_dump(mode="json")
    for clock in ("solve_time", "build_time", "evaluation_time"):
        data["solver"].pop(clock, None)
    for start in data["solver"].get("starts") or []:
        for clock in ("solve_time", "time"):
            start.pop(clock, None)
    return data


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
        equal = _comparable(results["new"]) == _comparable(results["old"])
        print(f"{name:24} {old:8.3f} {new:8.3f} {new / old:8.3f} "
              f"{results['new'].robust.rounds:6d}  {equal}")
    print(f"{'all':24} {total['old']:8.3f} {total['new']:8.3f} "
          f"{total['new'] / total['old']:8.3f}")
    print(f"load after {os.getloadavg()}")


if __name__ == "__main__":
    main()
