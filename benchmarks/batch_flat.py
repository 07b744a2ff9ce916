#!/usr/bin/env python
"""A batch spec's flat-direction test (``feedtune.tuner.optimum.flat_tunables``): the NLP's
Jacobian and Hessian called with DMs (``solver.get_function(name)(...)``, as before branch
h-bst5) against their evaluation buffers (``optimum._derivative``), in this process,
alternately, ``--rounds`` times.

The first ``--specs`` specs of ``batch_throughput.py`` are tuned once (after one untimed
spec of each structure) while each call of ``flat_tunables`` records its arguments; then,
per round, each recorded call runs both ways, checking that both give the same tunables
and that the Jacobian and Hessian are the same bits. Prints CPU ms a spec for each
(``time.process_time``; one BLAS thread) and the ratio.

    .venv/bin/python benchmarks/batch_flat.py --specs 60 --rounds 3
"""

from __future__ import annotations

import os

for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(1, str(Path(__file__).resolve().parent))

from batch_throughput import generate, one_spec_per_structure  # noqa: E402

import feedtune.batch.job as job  # noqa: E402
from feedtune.tuner import nlp, optimum  # noqa: E402


class _ThroughDMs:
    """``optimum._derivative`` as before: the solver's Function, called with DMs."""

    def __init__(self, solver, name):
        self.function = solver.get_function(name)

    def __call__(self, *args):
        out = self.function(*args)
        return ([np.asarray(o.full()) for o in out] if isinstance(out, (tuple, list))
                else np.asarray(out.full()))


def record(specs: list[dict]) -> list:
    """The arguments of every ``flat_tunables`` call of tuning ``specs`` once."""
    recorded = []
    flat = nlp.flat_tunables

    def spy(solver, solution, variables):
        recorded.append((solver, solution, variables))
        return flat(solver, solution, variables)

    nlp.flat_tunables = spy
    try:
        for spec in specs:
            job.solve(json.dumps(spec).encode())
    finally:
        nlp.flat_tunables = flat
    return recorded


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--specs", type=int, default=60)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args(argv)
    specs = generate(max(args.specs, 300))
    for spec in one_spec_per_structure(specs):
        job.solve(json.dumps(spec).encode())
    calls = record(specs[:args.specs])
    buffered = optimum._derivative
    for solver, solution, _ in calls:  # the same bits both ways
        for name, inputs in (("nlp_jac_g", (solution.x, solution.p)),
                             ("nlp_hess_l", (solution.x, solution.p, 1.0, solution.lam_g))):
            a, b = _ThroughDMs(solver, name)(*inputs), buffered(solver, name)(*inputs)
            assert all(np.array_equal(x, y) for x, y in zip(a, b)) if isinstance(a, list) \
                else np.array_equal(a, b), name
    cpu = {"DMs": 0.0, "buffers": 0.0}
    load = os.getloadavg()[0]
    for _ in range(args.rounds):
        for way in cpu:
            optimum._derivative = _ThroughDMs if way == "DMs" else buffered
            started = time.process_time()
            found = [optimum.flat_tunables(*c) for c in calls]
            cpu[way] += time.process_time() - started
            if way == "DMs":
                expected = found
            assert found == expected
    optimum._derivative = buffered
    n = args.specs * args.rounds
    print(f"{len(calls)} flat-direction tests of {args.specs} specs, {args.rounds} rounds; "
          f"load average {load:.2f} before, {os.getloadavg()[0]:.2f} after")
    for way, seconds in cpu.items():
        print(f"  {way:8s} {seconds / n * 1e3:.3f} ms a spec")
    print(f"  ratio DMs / buffers {cpu['DMs'] / cpu['buffers']:.2f}; same tunables and bits")
    return 0


if __name__ == "__main__":
    sys.exit(main())
