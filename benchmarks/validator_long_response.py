"""The validator's time grid, propagation and ISE on a 31-million-step response, this
checkout's against a git revision's, side by side in one process (issue 15).

The long-lived PID + notch design of ``tests/cli/test_pid_notch_example.py`` (a mode at
1717 rad/s decaying at 0.13 1/s) keeps the validator's fine step for 31 million steps;
``feedtune.tune`` of it spends nearly all its CPU re-measuring the reported ISE after a step
and after a ramp (``validate/linear.py``'s ``_transients``, ``continuous._graded_steps``,
``_propagate``, ``integrals.error_integrals``). Printed per part, per round: the CPU [s] of
the baseline's functions (``continuous.py`` and ``integrals.py`` of ``--baseline``, loaded
beside this checkout's) and of this checkout's, and whether every number is the same bits:
the steps, the times, both transients and both ISE values. Then ``_propagate`` on random
runs (vector and matrix states, with and without an output row): the same bits.

    .venv/bin/python benchmarks/validator_long_response.py [--baseline main] [--rounds 2]
"""

from __future__ import annotations

import argparse
import gc
import json
import sys
import time
from pathlib import Path

import numpy as np
from baseline import baseline_module, short_revision

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from feedtune.validate import continuous, integrals  # noqa: E402
from feedtune.validate.continuous import grid_times  # noqa: E402
from feedtune.validate.linear import LinearModel  # noqa: E402
from validator_integrals import LONG_LIVED  # noqa: E402  (the long-lived design)


def parts(cont, integ, model: LinearModel, times) -> tuple[dict[str, float], list]:
    """CPU [s] per part and the numbers, with ``cont``/``integ`` as the two modules."""
    cpu, numbers = {}, []

    def clock(name, function, *args):
        gc.collect()
        start = time.process_time()
        value = function(*args)
        cpu[name] = time.process_time() - start
        return value

    steps = clock("grid steps", cont.ContinuousModel._graded_steps, model)
    t = clock("grid times", times, steps)
    starts = np.column_stack([model._steady(kind)[2] for kind in ("step", "ramp")])
    values = clock("propagation", cont._propagate, model.a, starts, steps, model.c)
    numbers += [steps, t, values]
    for column, kind in enumerate(("step", "ramp")):
        e = -values[:, column]
        numbers.append(clock(f"ISE after a {kind}", integ.error_integrals, t, e, ("ise",)))
    return cpu, numbers


def same(a, b) -> bool:
    if isinstance(a, dict):
        return a == b
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", default="main")
    parser.add_argument("--rounds", type=int, default=2)
    args = parser.parse_args()
    old_cont = baseline_module(args.baseline, "feedtune/validate/continuous.py",
                               "baseline_continuous")
    old_integ = baseline_module(args.baseline, "feedtune/validate/integrals.py",
                                "baseline_integrals")
    spec = json.loads((REPO / "examples" / "user-defined-pid-notch.json").read_text())
    model = LinearModel(spec["plant"], LONG_LIVED)
    print(f"baseline {args.baseline} ({short_revision(args.baseline)}); CPU s")
    for round_ in range(args.rounds):
        before, old = parts(old_cont, old_integ, model,
                            lambda s: np.concatenate([[0.0], np.cumsum(s)]))
        after, new = parts(continuous, integrals, model, grid_times)
        equal = all(same(a, b) for a, b in zip(old, new))
        print(f"round {round_ + 1}: {old[0].size} steps; every number the same bits: {equal}")
        for name in before:
            print(f"  {name:20s} baseline {before[name]:6.2f}  new {after[name]:6.2f}  "
                  f"({after[name] / max(before[name], 1e-9):.2f})")
        print(f"  {'all':20s} baseline {sum(before.values()):6.2f}  new "
              f"{sum(after.values()):6.2f}  ({sum(after.values()) / sum(before.values()):.2f})")
        del old, new
    rng = np.random.default_rng(15)
    equal, cases = True, 0
    for n in (2, 5, 9):
        m = rng.normal(size=(n, n)) - 3 * np.eye(n)
        for shape in ((n,), (n, 3)):
            z0 = rng.normal(size=shape)
            for length in (255, 256, 1000, 5 * continuous.RUN_BLOCK + 7):
                steps = np.concatenate([np.full(3, 1e-3), np.full(length, 2e-3),
                                        np.full(300, 3e-3)])
                for output in (None, rng.normal(size=n)):
                    a = old_cont._propagate(m, z0, steps, output)
                    b = continuous._propagate(m, z0, steps, output)
                    equal &= same(a, b)
                    cases += 1
    print(f"_propagate on {cases} random grids: the same bits {equal}")


if __name__ == "__main__":
    main()
