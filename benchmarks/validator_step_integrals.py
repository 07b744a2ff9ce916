"""The software servo's step integrals in the validator (``ServoModel.error_integrals``),
this checkout's against a git revision's, side by side in one process (issue 15).

Models: every bundled example's result in ``tests/data/validation-golden.json`` whose plant
is a ``software_servo`` (exact model; sampled and reference pulse), and a grid of sampled
loops (K·T for ζ from ≈ 0.1 to over 1, τ or none, 0–2 samples of computation delay) and of
reference-pulse loops (Kτ from 0.05 to 25). Printed: the CPU [ms a model] of each tree's
``error_integrals`` on a fresh model (no cached matrices), and, for IAE, ISE and ITAE, the
largest relative difference of each tree's value from an independent reference: the dense
step response (``step_error``, the exact state on a grid) at 2048 and 4096 sub-steps per
block, trapezoid with exact sign splits (``validate/integrals.py``), Richardson-extrapolated
(4·I(4096) − I(2048))/3; for the examples also from the tuner's reported value (its own
exact sums, ``feedtune.loops``).

    .venv/bin/python benchmarks/validator_step_integrals.py [--baseline main] [--rounds 3]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

from baseline import baseline_module, short_revision  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from feedtune.validate.integrals import error_integrals  # noqa: E402
from feedtune.validate.software_servo import ServoModel  # noqa: E402

NAMES = ("iae", "ise", "itae")
TAU = 0.02


def _examples() -> list[tuple[str, dict, dict, dict]]:
    """(name, plant, tuned, reported step integrals) of the golden software-servo results."""
    golden = json.loads((REPO / "tests" / "data" / "validation-golden.json").read_text())
    cases = []
    for name, case in sorted(golden.items()):
        result = case["result"]
        plant = result["spec"]["plant"]
        if plant.get("type") != "software_servo" or plant.get("model", "exact") != "exact":
            continue
        reported = {m["metric"]: m["value"] for m in result["metrics"].values()
                    if m["metric"] in NAMES
                    and (m.get("options") or {}).get("time", "absolute") == "absolute"
                    and (m.get("options") or {}).get("input", "step") == "step"}
        cases.append((name, plant, {k: t["value"] for k, t in result["tuned"].items()},
                      reported))
    return cases


def _grid() -> list[tuple]:
    """(gain, τ, period, delay) of the generated loops, all stable."""
    loops = []
    for tau in (TAU, None):
        for period in (1 / 256, 1 / 64, 1 / 16):
            for delay in (0, 1, 2):
                for kt in (0.02, 0.1, 0.25, 0.5):
                    model = ServoModel(kt / period, tau, period, delay)
                    if model.stable():
                        loops.append((kt / period, tau, period, delay))
    for k_tau in (0.05, 0.25, 1.0, 5.0, 25.0):
        loops.append((k_tau / TAU, TAU, None, 0))
    return loops


def _reference(model) -> dict[str, float]:
    """Richardson-extrapolated dense trapezoid (2048 and 4096 sub-steps a block)."""
    coarse = error_integrals(*model.step_error(2048)[:2])
    fine = error_integrals(*model.step_error(4096)[:2])
    return {n: (4 * fine[n] - coarse[n]) / 3 for n in NAMES}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", default="main")
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    old = baseline_module(args.baseline, "feedtune/validate/software_servo.py",
                          "baseline_servo")
    sets = {"examples": _examples(),
            "grid": [(str(loop), None, loop, {}) for loop in _grid()]}
    print(f"baseline {args.baseline} ({short_revision(args.baseline)}); one BLAS thread; "
          f"load {os.getloadavg()[0]:.1f}")
    for label, cases in sets.items():
        def build(module, plant, tuned):
            if plant is not None:
                return module.ServoModel.from_result(plant, tuned)
            return module.ServoModel(*tuned)

        cpu = {"baseline": 0.0, "new": 0.0}
        values = {"baseline": [], "new": []}
        for _ in range(args.rounds):
            for key, module in (("baseline", old), ("new", sys.modules[ServoModel.__module__])):
                got = []
                for _, plant, tuned, _ in cases:
                    model = build(module, plant, tuned)
                    start = time.process_time()
                    got.append(model.error_integrals())
                    cpu[key] += time.process_time() - start
                values[key] = got
        worst = {key: dict.fromkeys(NAMES, 0.0) for key in ("baseline", "new", "new/reported",
                                                           "baseline/reported")}
        for i, (_, plant, tuned, reported) in enumerate(cases):
            reference = _reference(build(sys.modules[ServoModel.__module__], plant, tuned))
            for name in NAMES:
                for key in ("baseline", "new"):
                    value = values[key][i][name]
                    worst[key][name] = max(worst[key][name], abs(value / reference[name] - 1))
                    if name in reported:
                        worst[f"{key}/reported"][name] = max(
                            worst[f"{key}/reported"][name], abs(value / reported[name] - 1))
        n = len(cases) * args.rounds
        print(f"{label}: {len(cases)} models, CPU a model baseline "
              f"{cpu['baseline'] / n * 1e3:.3f} ms, new {cpu['new'] / n * 1e3:.3f} ms "
              f"({cpu['new'] / cpu['baseline']:.2f})")
        for key, row in worst.items():
            if any(row.values()) or not key.endswith("reported"):
                cells = ", ".join(f"{name} {row[name]:.1e}" for name in NAMES)
                against = "reported" if key.endswith("reported") else "reference"
                print(f"  largest |value/{against} − 1|, {key.split('/')[0]}: {cells}")


if __name__ == "__main__":
    main()
