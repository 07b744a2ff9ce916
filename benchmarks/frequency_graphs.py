#!/usr/bin/env python
"""The symbolic peaks and crossings of ``feedtune/loops/frequency.py``, old and new side by side (issue 15).

On a loop of symbols the metrics M_peak, sensitivity peak, bandwidth, gain and phase margin
and crossover frequency build the refined peak or crossing as a CasADi graph: the metric
contract differentiates it for every plant configuration (tests/contract), and the tuner
builds it into the NLP for a margin or crossover in a spec (``examples/user-defined-drive.json``)
and for a maximised gain margin. This script loads the baseline's ``frequency.py``
(``--baseline REV``, default b35710a) beside this checkout's, in one process, and for each
version in turn, interleaved:

* **contract**: every frequency-metric case of the metric contract
  (``tests/contract/contract_cases.py``), as ``test_metric_is_finite_with_finite_gradient``
  builds it: the metric on the loop of symbols, ``casadi.jacobian`` of it, the Function and
  its call at the nominal point; CPU per phase, and the largest difference of the two
  versions' values and gradients (relative to the value's and the gradient's size);
* **tunings**: specs whose NLP holds such a graph, tuned from scratch (the solver cache
  cleared): CPU, the objective, IPOPT's iterations and the tuned values of both.

Usage::

    .venv/bin/python benchmarks/frequency_graphs.py             # both parts
    .venv/bin/python benchmarks/frequency_graphs.py --no-tunings
"""

from __future__ import annotations

import os

for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")  # as the feedtune command does

import argparse  # noqa: E402
import collections  # noqa: E402
import contextlib  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402

from baseline import baseline_module, short_revision  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "contract"))

import feedtune.loops.frequency as new_frequency  # noqa: E402
from contract_cases import (exact_expr, log_point, metric_cases, narrow_box,  # noqa: E402
                            nominal, symbolic_loop)
from feedtune.expr import PoleRegion, Unbounded  # noqa: E402
from feedtune.objectives import METRICS  # noqa: E402

BASELINE = "b35710a"
METRIC_NAMES = ("m_peak", "sensitivity_peak", "bandwidth", "gain_margin", "phase_margin",
                "crossover_frequency")
#: the modules that import peaks and crossings from feedtune.loops.frequency, and the names
PATCHED = {
    "feedtune.objectives.frequency.frequency_domain": ("first_crossing",),
    "feedtune.objectives.frequency.bandwidth": ("first_crossing", "lowest_value"),
    "feedtune.objectives.frequency.sensitivity_peak": ("peak",),
    "feedtune.objectives.frequency.m_peak": ("peak",),
    "feedtune.objectives.frequency.gain_margin": ("crossing_if_any",),
}
SERVO = {"type": "software_servo", "technique": "sampled_data", "time_constant": 0.02,
         "computation_delay": 1}
BOX = {"position_gain": {"min": 1, "max": 200}, "sampling_period": {"min": 0.002, "max": 0.02}}
#: specs whose NLP holds a symbolic crossing or peak: the two bundled ones with a phase
#: margin bound, and tests/unit/test_sampled_frequency.py's widest gain margin and widest
#: bandwidth with margins (K and T free)
TUNINGS = {
    "user-defined-drive": ROOT / "examples" / "user-defined-drive.json",
    "user-defined-sampled-drive": ROOT / "examples" / "user-defined-sampled-drive.json",
    "widest-gain-margin": {
        "name": "widest-gain-margin", "plant": SERVO, "tunables": BOX,
        "objective": [{"metric": "gain_margin", "goal": "maximize"}],
        "constraints": [{"metric": "crossover_frequency", "min": 30},
                        {"metric": "sampling_ratio", "min": 0.25}],
        "solver": {"multistart": 2}},
    "widest-bandwidth-with-margins": {
        "name": "widest-bandwidth-with-margins", "plant": SERVO, "tunables": BOX,
        "objective": [{"metric": "bandwidth", "goal": "maximize"}],
        "constraints": [{"metric": "m_peak", "max": 1.3}, {"metric": "phase_margin", "min": 45},
                        {"metric": "gain_margin", "min": 2},
                        {"metric": "sampling_ratio", "min": 0.25}],
        "solver": {"multistart": 2}},
}


@contextlib.contextmanager
def using(module):
    """The metrics read their peaks and crossings from ``module`` inside the block."""
    import importlib
    saved = []
    for name, attributes in PATCHED.items():
        target = importlib.import_module(name)
        for attribute in attributes:
            saved.append((target, attribute, getattr(target, attribute)))
            setattr(target, attribute, getattr(module, attribute))
    try:
        yield
    finally:
        for target, attribute, value in saved:
            setattr(target, attribute, value)


def contract_case(config, name, options):
    """(CPU of evaluate, jacobian, call [s], value, gradient) as the contract's test does."""
    z, loop = symbolic_loop(config, narrow_box(config, nominal(config)))  # a fresh loop
    metric = METRICS[name]()
    start = time.process_time()
    value = metric.evaluate(loop, options)
    if isinstance(value, Unbounded):
        value = value.finite
    expr = ca.MX(exact_expr(value))
    built = time.process_time()
    jacobian = ca.jacobian(expr, z)
    differentiated = time.process_time()
    symbolic, gradient = ca.Function("metric", [z], [expr, jacobian])(
        log_point(config, nominal(config)))
    called = time.process_time()
    return (built - start, differentiated - built, called - differentiated, float(symbolic),
            np.array(gradient, dtype=float).ravel())


def contract(versions) -> None:
    cases = [(c, n, o) for c, n, o in metric_cases() if n in METRIC_NAMES]
    cpu = {label: collections.defaultdict(lambda: np.zeros(3)) for label, _ in versions}
    worst = [0.0, 0.0, 0.0]  # value, gradient (relative), cases with the same bits
    for config, name, options in cases:
        probe_loop = symbolic_loop(config, narrow_box(config, nominal(config)))[1]
        if not METRICS[name]().optimisable(probe_loop, options):
            continue
        if isinstance(METRICS[name]().evaluate(probe_loop, options), PoleRegion):
            continue
        results = {}
        for label, module in versions:
            with using(module):
                *phases, value, gradient = contract_case(config, name, options)
            cpu[label][name] += phases
            results[label] = (value, gradient)
        (v_old, g_old), (v_new, g_new) = results.values()
        worst[0] = max(worst[0], abs(v_new - v_old) / max(abs(v_old), 1e-300))
        worst[1] = max(worst[1], float(np.max(np.abs(g_new - g_old), initial=0.0))
                       / max(float(np.max(np.abs(g_old), initial=0.0)), 1.0))
        worst[2] += v_new == v_old and np.array_equal(g_new, g_old)
    print(f"metric contract, {len(cases)} cases of {', '.join(METRIC_NAMES)}: CPU [s] "
          "of evaluate / jacobian / call")
    labels = [label for label, _ in versions]
    print(f"{'metric':22s} " + " ".join(f"{label:>24s}" for label in labels) + "   ratio")
    totals = {label: np.zeros(3) for label in labels}
    for name in METRIC_NAMES:
        row = [cpu[label][name] for label in labels]
        for label, r in zip(labels, row):
            totals[label] += r
        print(f"{name:22s} " + " ".join(f"{r[0]:6.2f} {r[1]:6.2f} {r[2]:6.2f}    " for r in row)
              + f"  {row[1].sum() / row[0].sum():.3f}")
    print(f"{'all':22s} " + " ".join(f"{totals[label][0]:6.2f} {totals[label][1]:6.2f} "
                                     f"{totals[label][2]:6.2f}    " for label in labels)
          + f"  {totals[labels[1]].sum() / totals[labels[0]].sum():.3f}")
    print(f"values: largest relative difference {worst[0]:.2e}; gradients: largest "
          f"difference {worst[1]:.2e} of max(|gradient|, 1); {int(worst[2])} cases the same bits")


def tunings(versions, rounds: int) -> None:
    from feedtune.api import tune
    from feedtune.tuner.cache import clear_solver_cache

    print("\ntunings (solver cache cleared before each): CPU [s], objective, iterations")
    for name, spec in TUNINGS.items():
        seen = {}
        for _ in range(rounds):
            for label, module in versions:
                clear_solver_cache()
                with using(module):
                    start = time.process_time()
                    result = tune(spec)
                    cpu = time.process_time() - start
                solver = result.data.solver
                seen.setdefault(label, []).append(cpu)
                seen[label + "/result"] = (result.success, solver.iterations, result.data.objective,
                                           {k: v.value for k, v in result.tuned.items()})
        old, new = (min(seen[label]) for label, _ in versions)
        (s_old, it_old, obj_old, x_old), (s_new, it_new, obj_new, x_new) = (
            seen[label + "/result"] for label, _ in versions)
        print(f"{name:32s} old {old:6.2f} s new {new:6.2f} s ratio {new / old:.3f}; success "
              f"{s_old}/{s_new}, iterations {it_old}/{it_new}, objective {obj_old!r}/{obj_new!r}")
        for key in x_old:
            if x_old[key] != x_new[key]:
                print(f"{'':32s} {key}: {x_old[key]!r} / {x_new[key]!r}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", default=BASELINE, help="git revision of the old module")
    parser.add_argument("--no-tunings", action="store_true", help="the contract's cases only")
    parser.add_argument("--rounds", type=int, default=2, help="tunings per version (min kept)")
    args = parser.parse_args()
    old = baseline_module(args.baseline, "feedtune/loops/frequency.py", "old_frequency")
    old._LOG_OMEGA = new_frequency._LOG_OMEGA  # the loops' shared ω: responses built once
    versions = [(f"old {short_revision(args.baseline)}", old), ("new", new_frequency)]
    contract(versions)
    if not args.no_tunings:
        tunings(versions, args.rounds)


if __name__ == "__main__":
    main()
