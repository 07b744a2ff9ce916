"""The sampled LTI loop's linear solves: CasADi's symbolic QR (``linalg.solve``, the
baseline) against partial pivoting (``linalg.pivoted_solve``), side by side in one process.

On the README's sampled drive (examples/user-defined-sampled-drive.json at its tuned
gains) it builds the closed loop's H(e^{jωT}) on symbols with each solve, expanded to SX as
the NLP does, and prints per solve: SX instructions, build time, evaluation time (CPU), and
the error of H(1) and C_v against their exact values (1, and K_p without feed-forward).

    .venv/bin/python benchmarks/sampled_solve.py [--repeat 2000]
"""

from __future__ import annotations

import argparse
import copy
import json
import time
from pathlib import Path

import casadi as ca

from feedtune.loops import linalg
from feedtune.plants import plant_for
from feedtune.schema.spec import parse_spec

SPEC = json.loads((Path(__file__).resolve().parents[1] / "examples"
                   / "user-defined-sampled-drive.json").read_text())
TUNED = {"position_controller.kp": 138.0077020197471,
         "velocity_controller.kp": 1.0334019397647496}


def measure(solve, repeat: int) -> dict:
    pivoted = linalg.pivoted_solve
    linalg.pivoted_solve = solve
    try:
        spec = copy.deepcopy(SPEC)
        spec["plant"]["velocity_feedforward"] = 0.0  # C_v = K_p exactly (the velocity PI)
        plant = plant_for(parse_spec(spec).plant)
        box = {"position_controller.kp": (10, 1000), "velocity_controller.kp": (0.01, 10),
               "velocity_controller.ti": (0.01, 0.01), "sampling_period": (1e-3, 1e-3)}
        z, w = ca.MX.sym("z", 2), ca.MX.sym("w")
        start = time.process_time()
        loop = plant.loop({"position_controller.kp": z[0], "velocity_controller.kp": z[1],
                           "velocity_controller.ti": 0.01, "sampling_period": 1e-3}, box)
        response = ca.Function("H", [z, w], list(loop.frequency_response(w))).expand()
        exact = ca.Function("exact", [z], [loop.dc_gain(), loop.velocity_constant]).expand()
        build = time.process_time() - start
        x = [TUNED["position_controller.kp"], TUNED["velocity_controller.kp"]]
        start = time.process_time()
        for _ in range(repeat):
            response(x, 100.0)
        evaluation = (time.process_time() - start) / repeat
        dc, cv = (float(v) for v in exact(x))
        return {"instructions": response.n_instructions(), "build": build,
                "evaluation": evaluation, "dc_error": abs(dc - 1),
                "cv_error": abs(cv / TUNED["position_controller.kp"] - 1)}
    finally:
        linalg.pivoted_solve = pivoted


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeat", type=int, default=2000)
    repeat = parser.parse_args().repeat
    old = measure(linalg.solve, repeat)
    new = measure(linalg.pivoted_solve, repeat)
    for name, row in (("QR (baseline)", old), ("pivoted", new)):
        print(f"{name:14s} instructions {row['instructions']:6d}  build {row['build']:.3f} s  "
              f"H(ω) {row['evaluation'] * 1e6:7.1f} µs  |H(1) − 1| {row['dc_error']:.1e}  "
              f"|C_v/K_p − 1| {row['cv_error']:.1e}")
    print(f"ratio pivoted/QR: instructions {new['instructions'] / old['instructions']:.2f}, "
          f"evaluation {new['evaluation'] / old['evaluation']:.2f}")


if __name__ == "__main__":
    main()
