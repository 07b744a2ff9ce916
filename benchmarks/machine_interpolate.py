#!/usr/bin/env python
"""Part program → reference: parse a 10 000-block program and interpolate it, vectorised
(``feedtune.machine.interpolate``) against a naive per-sample loop, side by side in one
process.

The program is generated with a fixed seed: a random walk of G1 lines and G2/G3 arcs by
R (0.2–2 mm chords, 1000–4000 mm/min), absolute mm with 3 decimals, a G9 stop every 500
blocks. Both interpolators use the same feed rules (trapezoid at a = 2 m/s², corner rule
ε = 5 µm, τ = 10 ms); the baseline computes junction speeds with a Python loop over
blocks (forward and backward passes) and every sample with its own block search and
``Segment.point_at`` call, the way a first version would. Their references are compared
(largest distance between the two at equal sample index), and CPU (process_time) and wall
times printed with the ratio and the load average.

``--pulses`` adds Tian's V-F pulse generation (``pulse_reference``) on the same program at
BLU 10 µm and T = 0.1 ms (the fastest block, 4000 mm/min, moves 6.7 µm a period: at most
one pulse): the counters of ``interpolate._vf_counters`` (error limit one BLU, no
acceleration law: the command itself, no recursion) beside Tian's recursion period by
period on every axis (``feedtune.loops.pulse_train._track``, what ``pulse_reference`` ran
before), checked equal pulse for pulse.

Usage::

    .venv/bin/python benchmarks/machine_interpolate.py [--blocks 10000] [--period 1e-3] [--pulses]
"""

from __future__ import annotations

import argparse
import math
import os
import time

import numpy as np

from feedtune.machine.gcode import parse_program
from feedtune.loops.pulse_train import _track
from feedtune.machine.interpolate import _vf_counters, corner_speed, interpolate, pulse_reference
from feedtune.machine.path import Arc

ACCEL, EPS, TAU = 2.0, 5e-6, 0.01


def program_text(blocks: int, seed: int = 1) -> str:
    rng = np.random.default_rng(seed)
    lines = ["%", "(generated for benchmarks/machine_interpolate.py)", "G21 G90 G17", "G0 X0 Y0"]
    x = y = 0.0
    heading = 0.0
    for n in range(blocks):
        heading += rng.normal(0.0, 0.6)
        chord = rng.uniform(0.2, 2.0)
        nx, ny = round(x + chord * math.cos(heading), 3), round(y + chord * math.sin(heading), 3)
        if (nx, ny) == (x, y):
            continue
        feed = int(rng.uniform(1000, 4000))
        stop = "G9 " if n % 500 == 499 else ""
        if rng.random() < 0.5:
            lines.append(f"N{n + 1} {stop}G1 X{nx:.3f} Y{ny:.3f} F{feed}")
        else:
            half = math.hypot(nx - x, ny - y) / 2
            r = round(half * rng.uniform(1.05, 4.0) + 0.001, 3)
            lines.append(f"N{n + 1} {stop}{rng.choice(['G2', 'G3'])} X{nx:.3f} Y{ny:.3f} "
                         f"R{r:.3f} F{feed}")
        x, y = nx, ny
    lines += ["M30", "%"]
    return "\n".join(lines) + "\n"


def naive(path, period: float):
    """The same reference by Python loops: per block for junctions, per sample for points."""
    segs = path.segments
    n = len(segs)
    L = [s.length for s in segs]
    F = [s.feed for s in segs]
    cap = [0.0] * (n + 1)
    for j in range(1, n):
        a, b = segs[j - 1], segs[j]
        stop = a.exact_stop or getattr(a, "rapid", False) or getattr(b, "rapid", False)
        t1 = a.tangent_at([a.length])[0]
        t2 = b.tangent_at([0.0])[0]
        turn = math.acos(max(-1.0, min(1.0, float(t1 @ t2))))
        cap[j] = 0.0 if stop else min(F[j - 1], F[j], float(corner_speed(turn, EPS, TAU, ACCEL)))
    if segs[-1].exact_stop or getattr(segs[-1], "rapid", False):
        cap[n] = 0.0
    w = [c * c for c in cap]
    for j in range(n):
        w[j + 1] = min(w[j + 1], w[j] + 2 * ACCEL * L[j])
    for j in range(n - 1, -1, -1):
        w[j] = min(w[j], w[j + 1] + 2 * ACCEL * L[j])
    phases = []
    t0 = 0.0
    for k in range(n):
        va, vb = math.sqrt(w[k]), math.sqrt(w[k + 1])
        vp = math.sqrt(min(F[k] ** 2, 0.5 * (2 * ACCEL * L[k] + w[k] + w[k + 1])))
        vp = max(vp, va, vb)
        sa = min(max((vp * vp - w[k]) / (2 * ACCEL), 0.0), L[k])
        sd = min(max((vp * vp - w[k + 1]) / (2 * ACCEL), 0.0), L[k] - sa)
        ta, td = (vp - va) / ACCEL, (vp - vb) / ACCEL
        tc = (L[k] - sa - sd) / vp if vp > 0 else 0.0
        phases.append((t0, ta, tc, va, vp, sa))
        t0 += ta + tc + td
    count = int(math.ceil(t0 / period - 1e-9)) + 1
    out = np.empty((count, 3))
    k = 0
    for i in range(count):
        t = i * period
        while k < n - 1 and t >= phases[k + 1][0]:
            k += 1
        start, ta, tc, va, vp, sa = phases[k]
        tau = t - start
        if tau < ta:
            s = va * tau + 0.5 * ACCEL * tau * tau
        elif tau < ta + tc:
            s = sa + vp * (tau - ta)
        else:
            u = tau - ta - tc
            s = sa + vp * tc + vp * u - 0.5 * ACCEL * u * u
        s = min(max(s, 0.0), L[k])
        if i == count - 1:
            k, s = n - 1, L[-1]
        out[i] = segs[k].point_at([s])[0]
    return out


def recursion(command: np.ndarray) -> np.ndarray:
    """Every axis' counter by Tian's V-F recursion period by period (error limit one BLU,
    no acceleration law)."""
    out = np.empty_like(command)
    for axis in range(command.shape[1]):
        pulses, _ = _track(command[:, axis] - command[0, axis], 1.0, None)
        out[:, axis] = command[0, axis] + np.cumsum(pulses, dtype=np.int64)
    return out


def pulses(path) -> None:
    blu, period = 1e-5, 1e-4
    ref = interpolate(path, period=period, max_acceleration=ACCEL, corner_tolerance=EPS,
                      time_constant=TAU)
    command = np.rint(ref.position / blu).astype(np.int64)
    fast, f_cpu, f_wall = timed(_vf_counters, command, 1.0, None)
    slow, s_cpu, s_wall = timed(recursion, command)
    print(f"V-F counters, {len(command)} periods x 3 axes (BLU {blu:g} m, T = {period:g} s): "
          f"vectorised {f_cpu:.4f} s CPU ({f_wall:.4f} wall), recursion {s_cpu:.3f} s CPU "
          f"({s_wall:.3f} wall): {s_cpu / max(f_cpu, 1e-6):.0f}x; equal pulse for pulse: "
          f"{bool(np.array_equal(fast, slow))}")
    _, p_cpu, p_wall = timed(pulse_reference, ref, pulse_equivalent=blu)
    print(f"pulse_reference (counters, run-out, checks): {p_cpu:.3f} s CPU, {p_wall:.3f} s wall")


def timed(fn, *args, **kw):
    wall, cpu = time.perf_counter(), time.process_time()
    value = fn(*args, **kw)
    return value, time.process_time() - cpu, time.perf_counter() - wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--blocks", type=int, default=10_000, help="program blocks [count]")
    parser.add_argument("--period", type=float, default=1e-3, help="interpolation period T [s]")
    parser.add_argument("--repeats", type=int, default=3, help="runs of the vectorised one [count]")
    parser.add_argument("--pulses", action="store_true", help="also Tian's V-F pulse generation")
    args = parser.parse_args()
    text = program_text(args.blocks)
    program, p_cpu, p_wall = timed(parse_program, text, source="benchmark.ngc")
    path = program.path
    arcs = sum(isinstance(s, Arc) for s in path.segments)
    print(f"program: {len(path.segments)} blocks ({arcs} arcs), {len(text) / 1e3:.0f} kB, "
          f"{path.length:.3f} m; parse {p_cpu:.3f} s CPU, {p_wall:.3f} s wall")
    best = None
    for _ in range(args.repeats):
        ref, cpu, wall = timed(interpolate, path, period=args.period, max_acceleration=ACCEL,
                               corner_tolerance=EPS, time_constant=TAU)
        best = (cpu, wall) if best is None or cpu < best[0] else best
    print(f"samples: {len(ref.time)} at T = {args.period:g} s ({ref.time[-1]:.2f} s of motion)")
    print(f"vectorised interpolate: {best[0]:.3f} s CPU, {best[1]:.3f} s wall (best of {args.repeats})")
    base, b_cpu, b_wall = timed(naive, path, args.period)
    print(f"naive per-sample loop:  {b_cpu:.3f} s CPU, {b_wall:.3f} s wall")
    print(f"ratio naive/vectorised: {b_cpu / best[0]:.1f}x CPU, {b_wall / best[1]:.1f}x wall")
    diff = np.abs(base - ref.position).max()
    print(f"largest difference between the two references: {diff:.3g} m")
    if args.pulses:
        pulses(path)
    print(f"load average: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
