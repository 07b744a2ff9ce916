"""Issue 18 speed: a 10 000-block program on 3 axes simulated exactly, vectorised
(feedtune.machine.simulate.simulate_independent) beside a naive per-sample state recursion
of the same discrete loops, in one process; and tuning 3 axes (matched C_v and the feed
override, 100 µm) on a 1 000-block program, by this tree and by a baseline revision
(default ``main``, its ``feedtune/`` exported by ``git archive``), each in a child process
with its package first on PYTHONPATH, one after the other; CPU (process_time of the
child's tuning) and wall times, simulations, and the tuned C_v, feed and cycle time of
both with their differences. Prints CPU and wall times and the ratios.

    .venv/bin/python benchmarks/machine_simulate.py [--ccc] [--no-tune] [--baseline REV]

``--ccc`` also times Koren's cross-coupled controller (PI, K_c = 5, T_i = 50 ms) on two
10 000-block programs, the zig-zag of lines and a meander of lines and tangent arcs
(R 5–20 mm, where the estimate's quadratic arc term makes the vectorised simulation take
Newton passes): ``simulate_coupled`` (vectorised) beside ``simulate_coupled_stepped`` (the
coupled loop stepped sample by sample), with the largest difference; ``--no-tune`` leaves
the tuning out.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path as FilePath

import numpy as np

from feedtune.machine.path import Arc, Line, Path
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
        from feedtune.machine.simulate import simulate_coupled_stepped

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
    revision = sys.argv[sys.argv.index("--baseline") + 1] if "--baseline" in sys.argv else "main"
    sys.path.insert(0, str(FilePath(__file__).resolve().parent))
    from baseline import export_package, short_revision

    base = export_package(revision, FilePath(tempfile.mkdtemp(prefix="feedtune-baseline-")))
    here = FilePath(__file__).resolve().parents[1]
    rows = {}
    for name, package in ((f"baseline {short_revision(revision)}", base), ("this tree", here)):
        env = {**os.environ, "PYTHONPATH": str(package)}
        proc = subprocess.run([sys.executable, os.path.abspath(__file__), "--child"], env=env,
                              capture_output=True, text=True, check=True)
        rows[name] = json.loads(proc.stdout.strip().splitlines()[-1])
    for name, r in rows.items():
        print(f"tuning 3 matched axes + feed on 1 000 blocks, {name}: {r['cpu']:.1f} s CPU, "
              f"{r['wall']:.1f} s wall, {r['evaluations']} simulations, C_v {r['cv']:.5g} 1/s, "
              f"feed override {r['feed']:.5g}, cycle {r['cycle']:.3f} s, largest error "
              f"{r['error'] * 1e6:.3f} µm")
    old, new = rows.values()
    print(f"tuning ratio baseline/this: {old['cpu'] / new['cpu']:.2f}x CPU, "
          f"{old['wall'] / new['wall']:.2f}x wall; cycle time {new['cycle'] / old['cycle'] - 1:+.3%}, "
          f"C_v {new['cv'] / old['cv'] - 1:+.3%}, feed {new['feed'] / old['feed'] - 1:+.3%}")


def child() -> None:
    """The tuning, timed inside this process (the package on PYTHONPATH), as one JSON line."""
    import feedtune

    spec, path = machine(True), zigzag(1_000)
    tuned, cpu, wall = timed(tune_machine, spec, path)
    print(json.dumps({"cpu": cpu, "wall": wall, "evaluations": tuned["evaluations"],
                      "cv": tuned["velocity_constants"]["x"], "feed": tuned["feed_override"],
                      "cycle": tuned["metrics"]["cycle_time"],
                      "error": tuned["metrics"]["max_contour_error"],
                      "package": feedtune.__file__}))


if __name__ == "__main__":
    if "--child" in sys.argv:
        child()
        sys.exit()
    main()
    print(f"load average: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
