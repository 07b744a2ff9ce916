#!/usr/bin/env python
"""Where the metric contract's CPU goes, metric by metric and phase by phase (issue 15).

``tests/contract/test_metric_contract.py`` evaluates every registered metric on every plant
configuration it supports (2 140 cases): on the loop of numbers at the nominal point (its
value, and the located peak or crossing where the value is one), on the loop of numbers
with the plant's default box, and on the loop of log-tunable symbols (the value, its
exact expression, ``casadi.jacobian`` of it, the Function and its first call). This script
repeats those steps in one process, in the tests' order (after the test module's
collection, which evaluates the optimisable metrics on the loops of numbers), and prints the CPU
(``time.process_time``) of each phase per metric, so that the next change can be aimed at
the phase and metric that cost most. The reformulated test's pieces and the pole regions'
conditions are not repeated here (see benchmarks/README.md, branch h-tmc2).

Usage::

    .venv/bin/python benchmarks/metric_contract_phases.py             # every metric
    .venv/bin/python benchmarks/metric_contract_phases.py m_peak iae  # some
"""

from __future__ import annotations

import os

for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")  # as tests/conftest.py pins it

import argparse  # noqa: E402
import collections  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import casadi as ca  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "contract"))

from contract_cases import (as_float, exact_expr, log_point, metric_cases,  # noqa: E402
                            nominal, numeric_metric)
from feedtune.expr import PoleRegion, Unbounded  # noqa: E402
from feedtune.loops.loop import HorizonError  # noqa: E402
from feedtune.objectives import METRICS  # noqa: E402

PHASES = ("numbers: value", "numbers: located", "default box", "symbols: value",
          "symbols: exact", "symbols: jacobian", "symbols: Function + call")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("metrics", nargs="*", help="metric names (default: every metric)")
    args = parser.parse_args()
    start = time.process_time()
    import test_metric_contract as contract  # its collection: the cases and _reformulated

    print(f"collection (cases; every optimisable metric's value on the loop of numbers, "
          f"to find the reformulated ones): {time.process_time() - start:.3f} s of CPU")
    cpu = collections.defaultdict(float)
    count = collections.Counter()
    loops = {}
    for config, name, options in metric_cases():
        if args.metrics and name not in args.metrics:
            continue
        metric = METRICS[name]()
        if config not in loops:  # shared by the cases of a configuration, as in the tests
            loops[config] = (contract._default_box_loop(config), contract._symbolic_loop(config))
        default, (z, loop) = loops[config]
        count[name] += 1
        start = time.process_time()

        def tick(phase):
            nonlocal start
            now = time.process_time()
            cpu[name, phase] += now - start
            start = now

        value, _ = numeric_metric(config, name, options)
        tick("numbers: value")
        as_float(value)
        tick("numbers: located")
        try:
            as_float(metric.evaluate(default, options))
        except HorizonError:
            pass
        tick("default box")
        if not metric.optimisable(loop, options):
            continue
        value = metric.evaluate(loop, options)
        tick("symbols: value")
        if isinstance(value, PoleRegion):
            continue
        if isinstance(value, Unbounded):
            value = value.finite
        expr = ca.MX(exact_expr(value))
        tick("symbols: exact")
        jacobian = ca.jacobian(expr, z)
        tick("symbols: jacobian")
        ca.Function("metric", [z], [expr, jacobian])(log_point(config, nominal(config)))
        tick("symbols: Function + call")
    names = sorted(count, key=lambda n: -sum(cpu[n, p] for p in PHASES))
    print(f"{'metric':22s} {'cases':>5s} " + " ".join(f"{p:>13.13s}" for p in PHASES)
          + "   total [s of CPU]")
    for n in names:
        row = [cpu[n, p] for p in PHASES]
        print(f"{n:22s} {count[n]:5d} " + " ".join(f"{v:13.3f}" for v in row)
              + f" {sum(row):8.3f}")
    totals = [sum(cpu[n, p] for n in names) for p in PHASES]
    print(f"{'all':22s} {sum(count.values()):5d} " + " ".join(f"{v:13.3f}" for v in totals)
          + f" {sum(totals):8.3f}")


if __name__ == "__main__":
    main()
