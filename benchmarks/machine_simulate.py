"""Issue 18 speed: a 10 000-block program on 3 axes simulated exactly, vectorised
(feedtune.machine.simulate.simulate_independent) beside a naive per-sample state recursion
of the same discrete loops, in one process; and tuning 3 axes (matched) on a 1 000-block
program. Prints CPU and wall times and the ratio.

    .venv/bin/python benchmarks/machine_simulate.py [--ccc] [--no-tune]

``--ccc`` also times Koren's cross-coupled controller on the 10 000-block program (the
coupled axes stepped sample by sample); ``--no-tune`` leaves the tuning out.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from feedtune.machine.path import Line, Path
from feedtune.machine.contour import SegmentTable
from feedtune.machine.run import axis_models, nominal_setting, path_direction, run
from feedtune.machine.simulate import CrossCoupling, simulate_coupled, simulate_independent
from feedtune.machine.spec import parse_machine
from feedtune.machine.tune import tune_machine


def zigzag(blocks: int, feed: float = 0.05) -> Path:
    """A 3-D zig-zag of ``blocks`` 1 mm lines."""
    rng = np.random.default_rng(1)
    points = np.cumsum(np.vstack([np.zeros(3), 1e-3 * rng.normal(size=(blocks, 3))]), axis=0)
    return Path(tuple(Line(points[k], points[k + 1], feed) for k in range(blocks)))


def machine(tuned: bool):
    gain = {"min": 5, "max": 60, "initial": 20} if tuned else {"value": 20}
    axes = {n: {"plant": {"type": "software_servo", "technique": "sampled_data",
                          "time_constant": tau}, "tunables": {"position_gain": gain}}
            for n, tau in zip("xyz", (0.02, 0.025, 0.03))}
    raw = {"name": "bench", "axes": axes, "sampling_period": {"value": 1e-3},
           "interpolator": {"max_acceleration": 2.0}}
    if tuned:
        raw["feed_override"] = {"min": 0.1, "max": 3}
        raw["tuning"] = {"contour_tolerance": 1e-4, "matched": True}
    return parse_machine(raw)


def naive(models, reference):
    out = np.empty_like(reference)
    for i, m in enumerate(models):
        x = np.zeros(len(m.phi))
        r = reference[:, i]
        ahead = np.append(r[1:], r[-1])
        for k in range(len(r)):
            out[k, i] = m.c @ x + m.d * r[k]
            x = m.phi @ x + m.gamma[:, 0] * r[k] + m.gamma[:, 1] * ahead[k]
    return out


def timed(fn, *args):
    c, w = time.process_time(), time.perf_counter()
    value = fn(*args)
    return value, time.process_time() - c, time.perf_counter() - w


def main():
    spec = machine(False)
    path = zigzag(10_000)
    result, cpu, wall = timed(run, spec, path)
    print(f"10 000 blocks, 3 axes, {len(result.time)} samples: run() (interpolate, simulate, "
          f"metrics) {cpu:.3f} s CPU, {wall:.3f} s wall")
    models = axis_models(spec, nominal_setting(spec))
    reference = result.commanded
    fast, c1, w1 = timed(simulate_independent, models, reference - reference[0])
    slow, c2, w2 = timed(naive, models, reference - reference[0])
    print(f"simulation only: vectorised {c1:.3f} s CPU ({w1:.3f} wall), naive per-sample "
          f"{c2:.3f} s CPU ({w2:.3f} wall): {c2 / c1:.0f}x; largest difference "
          f"{np.max(np.abs(fast - slow)):.2e} m")
    if "--ccc" in sys.argv:
        tangent, curvature = path_direction(SegmentTable.of(path), result.arc_length,
                                        result.segment)
        _, c3, w3 = timed(simulate_coupled, models, reference, tangent, curvature,
                          CrossCoupling(5.0, 0.05))
        print(f"cross-coupled (3 axes, x-y coupled), per-sample stepping: {c3:.3f} s CPU "
              f"({w3:.3f} wall)")
    if "--no-tune" in sys.argv:
        return
    tuned, cpu, wall = timed(tune_machine, machine(True), zigzag(1_000))
    print(f"tuning 3 matched axes + feed on 1 000 blocks: {cpu:.1f} s CPU, {wall:.1f} s wall, "
          f"{tuned['evaluations']} simulations, status {tuned['status']}, "
          f"feed override {tuned['feed_override']:.4g}")


if __name__ == "__main__":
    main()
