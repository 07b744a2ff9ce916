"""Issue 18 speed: a 10 000-block program on 3 axes simulated exactly, vectorised
(feedtune.machine.simulate.simulate_independent) beside a naive per-sample state recursion
of the same discrete loops, in one process; and tuning 3 axes (matched) on a 1 000-block
program. Prints CPU and wall times and the ratio.

    .venv/bin/python benchmarks/machine_simulate.py [--ccc] [--no-tune]

``--ccc`` also times Koren's cross-coupled controller (PI, K_c = 5, T_i = 50 ms) on two
10 000-block programs, the zig-zag of lines and a meander of lines and tangent arcs
(R 5–20 mm, where the estimate's quadratic arc term makes the vectorised simulation take
Newton passes): ``simulate_coupled`` (vectorised) beside ``simulate_coupled_stepped`` (the
coupled loop stepped sample by sample), with the largest difference; ``--no-tune`` leaves
the tuning out.
"""

from __future__ import annotations

import math
import os
import sys
import time

import numpy as np

from feedtune.machine.path import Arc, Line, Path
from feedtune.machine.contour import SegmentTable
from feedtune.machine.run import axis_models, nominal_setting, path_direction, run
from feedtune.machine.simulate import (CrossCoupling, simulate_coupled, simulate_coupled_stepped,
                                       simulate_independent)
from feedtune.machine.spec import parse_machine
from feedtune.machine.tune import tune_machine


def zigzag(blocks: int, feed: float = 0.05) -> Path:
    """A 3-D zig-zag of ``blocks`` 1 mm lines."""
    rng = np.random.default_rng(1)
    points = np.cumsum(np.vstack([np.zeros(3), 1e-3 * rng.normal(size=(blocks, 3))]), axis=0)
    return Path(tuple(Line(points[k], points[k + 1], feed) for k in range(blocks)))


def meander(blocks: int, feed: float = 0.05) -> Path:
    """``blocks`` alternating 1 mm lines and tangent arcs in XY (R 5–20 mm, sweep
    0.05–0.5 rad, left or right at random)."""
    rng = np.random.default_rng(2)
    p, heading, segs = np.zeros(3), 0.0, []
    for k in range(blocks):
        d = np.array([math.cos(heading), math.sin(heading), 0.0])
        if k % 2 == 0:
            q = p + 1e-3 * d
            segs.append(Line(p, q, feed))
        else:
            radius, turn = rng.uniform(5e-3, 20e-3), rng.choice([-1, 1])
            sweep = rng.uniform(0.05, 0.5)
            centre = p + radius * turn * np.array([-d[1], d[0], 0.0])
            a1 = math.atan2(p[1] - centre[1], p[0] - centre[0]) + turn * sweep
            q = centre + radius * np.array([math.cos(a1), math.sin(a1), 0.0])
            segs.append(Arc(p, q, centre, ccw=turn > 0, feed=feed))
            heading += turn * sweep
        p = q
    return Path(tuple(segs))


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
        ccc = CrossCoupling(5.0, 0.05)
        for name, program in (("zig-zag of lines", path), ("meander of lines and arcs",
                                                           meander(10_000))):
            done = result if program is path else run(spec, program, detail=False)
            tangent, curvature = path_direction(SegmentTable.of(program), done.arc_length,
                                                done.segment)
            commanded = done.commanded
            fast, c3, w3 = timed(simulate_coupled, models, commanded, tangent, curvature, ccc)
            slow, c4, w4 = timed(simulate_coupled_stepped, models, commanded, tangent,
                                 curvature, ccc)
            print(f"cross-coupled, {name} ({len(commanded)} samples, 3 axes, x-y coupled): "
                  f"vectorised {c3:.3f} s CPU ({w3:.3f} wall), per-sample {c4:.3f} s CPU "
                  f"({w4:.3f} wall): {c4 / c3:.1f}x; largest difference "
                  f"{np.max(np.abs(fast - slow)):.2e} m")
    if "--no-tune" in sys.argv:
        return
    tuned, cpu, wall = timed(tune_machine, machine(True), zigzag(1_000))
    print(f"tuning 3 matched axes + feed on 1 000 blocks: {cpu:.1f} s CPU, {wall:.1f} s wall, "
          f"{tuned['evaluations']} simulations, status {tuned['status']}, "
          f"feed override {tuned['feed_override']:.4g}")


if __name__ == "__main__":
    main()
    print(f"load average: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
