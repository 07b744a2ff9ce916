#!/usr/bin/env python
"""The validator's sampled open loop at one ω, as brentq and bounded Brent call it (≈ 60
calls a batch spec: the minimum radius, the peaks, the crossings), against the same
formula solved as a stack of one system (how ``ServoModel.open_loop`` solved every call
before branch h-bst2). Both in this process, alternately, ``--rounds`` times; prints µs a
call (CPU) and the ratio, and checks that both give the same bits.

    .venv/bin/python benchmarks/validator_open_loop.py --rounds 5
"""

from __future__ import annotations

import os

for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import argparse  # noqa: E402
import math  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from feedtune.validate.software_servo import ServoModel  # noqa: E402


def stacked(model: ServoModel, omega) -> np.ndarray:
    """The open loop with Γ broadcast over a stack of resolvents (the old path)."""
    omega = np.atleast_1d(np.asarray(omega, dtype=float))
    phi, gamma, c, eye = model._resolvent_parts
    z = np.exp(1j * omega * model.period)
    resolvent = z[:, None, None] * eye - phi
    rhs = np.broadcast_to(gamma, (z.size, *gamma.shape))
    out = np.linalg.solve(resolvent, rhs)[:, :, 0] @ c
    return model.gain * z ** (-model.delay) * out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--calls", type=int, default=3000)
    args = parser.parse_args(argv)
    # Koren's sampled-data drive, no delay and one sample of delay
    models = [ServoModel(17.98, 0.02, 1 / 64), ServoModel(40.0, 0.01, 1 / 128, delay=1)]
    omegas = [float(w) for w in np.geomspace(0.1, math.pi * 64, args.calls)]
    same = all(model.open_loop(w).tobytes() == stacked(model, w).tobytes()
               for model in models for w in omegas[::10])
    times = {"stacked (before)": [], "one system (now)": []}
    for _ in range(args.rounds):
        for label, fn in (("stacked (before)", stacked),
                          ("one system (now)", lambda m, w: m.open_loop(w))):
            started = time.process_time()
            for model in models:
                for w in omegas:
                    fn(model, w)
            times[label].append((time.process_time() - started) / (len(models) * len(omegas)))
    print(f"load average {os.getloadavg()[0]:.2f}; same bits on every ω checked: {same}")
    best = {label: min(values) * 1e6 for label, values in times.items()}
    for label, value in best.items():
        print(f"{label}: {value:.1f} µs a call (best of {args.rounds} rounds, CPU)")
    print(f"ratio before/now: {best['stacked (before)'] / best['one system (now)']:.2f}")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
