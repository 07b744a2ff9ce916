"""Issue 18, the in-position wait: what it costs a machine run.

The same 3-axis machine and 2 000-block program (a zig-zag of 1 mm lines) run with the
interpolator alone and with ``in_position`` (1 µm), once with every block an exact stop
(G61: 2 000 stops, each hold found from that piece's simulated error) and once with
exact stops at every 100th block (20 stops). Prints CPU and wall time of each and the
ratio, in one process.

    .venv/bin/python benchmarks/machine_inposition.py
"""

from __future__ import annotations

import os
import time

import numpy as np

from feedtune.machine.path import Line, Path
from feedtune.machine.run import run
from feedtune.machine.spec import parse_machine


def zigzag(blocks: int, every: int, feed: float = 0.05) -> Path:
    """A plane zig-zag of ``blocks`` 1 mm lines, an exact stop after every ``every``-th."""
    rng = np.random.default_rng(1)
    steps = np.column_stack([1e-3 * rng.normal(size=(blocks, 2)), np.zeros(blocks)])
    points = np.cumsum(np.vstack([np.zeros(3), steps]), axis=0)
    return Path(tuple(Line(points[k], points[k + 1], feed, exact_stop=(k + 1) % every == 0)
                      for k in range(blocks)))


def machine(band: float | None):
    axes = {n: {"plant": {"type": "software_servo", "technique": "sampled_data",
                          "time_constant": tau}, "tunables": {"position_gain": {"value": 40}}}
            for n, tau in zip("xyz", (0.02, 0.025, 0.03))}
    interpolator = {"max_acceleration": 2.0}
    if band is not None:
        interpolator["in_position"] = band
    return parse_machine({"name": "bench", "axes": axes, "sampling_period": {"value": 1e-3},
                          "interpolator": interpolator})


def timed(fn, *args):
    c, w = time.process_time(), time.perf_counter()
    value = fn(*args)
    return value, time.process_time() - c, time.perf_counter() - w


def main():
    print(f"load average {os.getloadavg()[0]:.1f}")
    for every in (1, 100):
        path = zigzag(2_000, every)
        plain, c0, w0 = timed(run, machine(None), path)
        held, c1, w1 = timed(run, machine(1e-6), path)
        holds = held.metrics["interpolation"]["in_position"]
        print(f"2 000 blocks, a stop every {every}: without the wait {len(plain.time)} samples "
              f"{c0:.3f} s CPU ({w0:.3f} wall); with it {len(held.time)} samples, "
              f"{len(holds)} holds, {c1:.3f} s CPU ({w1:.3f} wall): {c1 / c0:.1f}x")


if __name__ == "__main__":
    main()
