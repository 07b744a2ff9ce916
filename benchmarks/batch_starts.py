#!/usr/bin/env python
"""A batch spec's starts and ``Problem.__init__``, the tuner's Function calls through DMs
against their evaluation buffers (feedtune.tuner.calls), and a problem of a built
structure with its rows built (as before branch h-bst4) against numbers only
(feedtune.tuner.builder.Lazy); both in this process, alternately, ``--rounds`` times.

The first ``--specs`` specs of ``batch_throughput.py`` are tuned once (after one untimed
spec of each structure) while every IPOPT solve's inputs, every NLP check's point and
every ``Problem`` construction's arguments are recorded; then, per round:

* each recorded IPOPT solve through ``solver(**inputs)`` and ``solver.stats()`` (DMs) and
  through its :class:`~feedtune.tuner.calls.NumericCall` (``named`` and ``stats``),
  checking that both give the same iterates, multipliers and iteration count;
* each recorded NLP check (``Evaluator.function`` at a start or an end point) both ways;
* each recorded ``Problem`` built again on its cached structure, with a symbolic builder
  (every row built, as before) and with the builder the tuner now gives it (numbers
  only), checking that both give the same parameter values and row bounds.

It prints CPU ms a spec for each (``time.process_time``; one BLAS thread) and the ratios.

    .venv/bin/python benchmarks/batch_starts.py --specs 60 --rounds 3
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
from feedtune.tuner import calls, nlp, structure  # noqa: E402
from feedtune.tuner.evaluation import Evaluator  # noqa: E402


def record(specs: list[dict]) -> tuple[list, list, list]:
    """(IPOPT solves: (solver, inputs), NLP checks: (Function, z, p), Problem arguments)
    of tuning ``specs`` once."""
    solves, checks, problems = [], [], []
    named, evaluate, init = calls.NumericCall.named, Evaluator.__call__, nlp.Problem.__init__

    def named_spy(self, **inputs):
        if "lbx" in inputs:  # an nlpsol
            solves.append((self.function, {k: np.array(v, dtype=float) for k, v in inputs.items()}))
        return named(self, **inputs)

    def evaluate_spy(self, z, p):
        checks.append((self.function, np.array(z, dtype=float), np.array(p[:self.n_params])))
        return evaluate(self, z, p)

    def init_spy(self, *args, **kwargs):
        problems.append((args, kwargs))
        init(self, *args, **kwargs)

    calls.NumericCall.named, Evaluator.__call__, nlp.Problem.__init__ = (named_spy, evaluate_spy,
                                                                       init_spy)
    try:
        for spec in specs:
            job.solve(json.dumps(spec).encode())
    finally:
        calls.NumericCall.named, Evaluator.__call__, nlp.Problem.__init__ = named, evaluate, init
    return solves, checks, problems


def solves_with_dms(solves) -> list:
    out = []
    for solver, inputs in solves:
        result = solver(**inputs)
        stats = solver.stats()
        out.append((np.asarray(result["x"], dtype=float).ravel(),
                    np.asarray(result["lam_g"], dtype=float).ravel(),
                    np.asarray(result["lam_x"], dtype=float).ravel(), stats["iter_count"]))
    return out


def solves_buffered(solves) -> list:
    out = []
    for solver, inputs in solves:
        call = calls.numeric(solver, check=False)
        result = call.named(**inputs)
        stats = call.stats()
        out.append((result["x"].ravel(), result["lam_g"].ravel(), result["lam_x"].ravel(),
                    stats["iter_count"]))
    return out


def checks_with_dms(checks) -> list:
    out = []
    for fn, z, p in checks:
        result = fn(z=z, p=p)
        out.append([np.asarray(result[name], dtype=float) for name in fn.name_out()])
    return out


def checks_buffered(checks) -> list:
    return [list(calls.numeric(fn).named(z=z, p=p).values()) for fn, z, p in checks]


def problems_built(problems, symbolic: bool | None) -> list:
    """Each recorded Problem made again; ``symbolic`` True: every row built (None: the
    tuner's own choice)."""
    original = structure.Structure.builder

    def symbolic_builder(self, variables, values):
        builder = original(self, variables, values)
        builder.symbolic = True
        return builder

    if symbolic:
        structure.Structure.builder = symbolic_builder
    try:
        return [nlp.Problem(*args, **kwargs) for args, kwargs in problems]
    finally:
        structure.Structure.builder = original


def _same(a, b) -> bool:
    return all(np.array_equal(x, y) for pair_a, pair_b in zip(a, b)
               for x, y in zip(pair_a, pair_b))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--specs", type=int, default=60)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args(argv)
    specs = generate(max(args.specs, 300))
    for spec in one_spec_per_structure(specs):
        job.solve(json.dumps(spec).encode())
    solves, checks, problems = record(specs[:args.specs])
    n = args.specs
    print(f"{n} specs: {len(solves)} IPOPT solves, {len(checks)} NLP checks, "
          f"{len(problems)} problems; load average {os.getloadavg()[0]:.2f}")
    # each recorded solve or check alone, the two ways in turn (a loaded machine's speed
    # drifts within a round); problems a round at a time (each builds the next's caches)
    pairs = [("IPOPT solves", solves_with_dms, solves_buffered, [[s] for s in solves]),
             ("NLP checks", checks_with_dms, checks_buffered, [[c] for c in checks]),
             ("Problem.__init__ on its structure", lambda p: problems_built(p, True),
              lambda p: problems_built(p, None), problems)]
    totals = {label: [0.0, 0.0] for label, *_ in pairs}
    for _ in range(args.rounds):
        for label, before, now, recorded in pairs:
            items = [recorded] if label == pairs[2][0] else recorded
            old, out = [], []
            for item in items:
                for i, (fn, outs) in enumerate(((before, old), (now, out))):
                    started = time.process_time()
                    outs.extend(fn(item))
                    totals[label][i] += time.process_time() - started
            if label == pairs[2][0]:
                same = all(all(np.array_equal(getattr(a, k), getattr(b, k)) for k in
                               ("param_values", "lbw", "ubw", "lbg", "ubg", "slot_defaults"))
                           for a, b in zip(old, out))
            else:
                same = _same(old, out)
            if not same:
                print(f"{label}: the two ways differ")
                return 1
    print(f"load average {os.getloadavg()[0]:.2f} at the end; every pair the same bits")
    print()
    print("| CPU ms a spec | before | now | ratio |")
    print("|---|---|---|---|")
    for label, (before, now) in totals.items():
        b, a = before / args.rounds / n * 1e3, now / args.rounds / n * 1e3
        print(f"| {label} | {b:.3f} | {a:.3f} | {b / a:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
