#!/usr/bin/env python
"""Issue 17's data-driven speed benchmark: the convex design on 3 data sets × 500
frequencies, side by side with scipy's nonlinear optimisers on the same problem.

The problem is ``examples/datadriven/hydraulic-three-loads.json``: Bhatia's hydraulic drive
measured at three load inertias (examples/datadriven/generate.py, seed 17), a PID with its
derivative filter fixed at 2 ms, K = k_p + k_i/s + k_d s/(0.002 s + 1); maximise the
lowest bandwidth over the sets with M_peak ≤ 1.3 and M_s ≤ 2 on every set (at the measured
points and the parabola between them) and the loop certified stable on every set.

* **convex**: :func:`feedtune.measured.datadriven.design` (iterated SOCPs, cvxpy + Clarabel)
  from the spec's initial gains, as ``feedtune tune`` runs it;
* **SLSQP** (scipy, finite-difference gradients) and **differential evolution** (scipy,
  seed 1, default population 15 × 3, constraints as one ``NonlinearConstraint``) over the
  logarithms of the three gains within the spec's box, on the same data and the same
  evaluation (:func:`~feedtune.measured.datadriven.set_metrics` and the Nyquist
  certificate; an uncertified point counts as infeasible), SLSQP from the same start.

Every answer is judged by that one evaluation. Times are wall clock and process CPU after
imports (cvxpy's import, ≈ 1 s, is paid once per process and printed apart); the load
average is printed. BLAS runs on one thread, as the ``feedtune`` command and the Python API
run it (on two threads of a loaded machine a 1 500 × 3 complex product took 416 µs of CPU
against 6.5 µs). Run from the repository: ``python benchmarks/datadriven_speed.py``.

``--baseline REV``: instead, this checkout's ``design`` against ``REV``'s
``feedtune/measured/datadriven.py`` loaded beside it in this process, in turn, ``--rounds``
times, on the example and on the weighted-sensitivity designs of
tests/unit/test_datadriven_weighted.py (the three loads modelled, 500 points): CPU of each,
the ratio, and whether the two designs agree in every field but their clocks.
"""

from __future__ import annotations

import json
import math
import os
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
from feedtune.__main__ import pin_blas_threads  # noqa: E402

pin_blas_threads()  # one BLAS thread, as `feedtune` runs (before numpy loads; every method)

import numpy as np  # noqa: E402
from scipy import optimize  # noqa: E402
SPEC_PATH = os.path.join(ROOT, "examples", "datadriven", "hydraulic-three-loads.json")

from feedtune.measured.datadriven import (ControllerBasis, design, nyquist_certificate,  # noqa: E402
                                          set_metrics, worst_case)
from feedtune.plants.frequency_response_data import (FrequencyResponseData,  # noqa: E402
                                                     FrequencyResponseDataParams)

M_PEAK, M_S = 1.3, 2.0


def timed(fn):
    wall, cpu = time.perf_counter(), time.process_time()
    out = fn()
    return out, time.perf_counter() - wall, time.process_time() - cpu


def evaluate(sets, basis: ControllerBasis, rho) -> tuple[dict, bool]:
    """(worst-case metrics, stable on every set) at ρ: the one evaluation every answer gets."""
    per_set, stable = [], True
    for data in sets:
        loop = data.response * basis.response(rho, data.omega)
        per_set.append(set_metrics(data, loop))
        stable &= nyquist_certificate(data, lambda w: basis.response(rho, w), 1,
                                      basis.integrators, 0).stable
    return worst_case(per_set), stable


def main() -> None:
    spec = json.load(open(SPEC_PATH))
    plant = FrequencyResponseData(FrequencyResponseDataParams.model_validate(spec["plant"]))
    sets, basis = plant.sets(), plant.basis()
    names = basis.names
    box = {n: (spec["tunables"][f"controller.{n}"]["min"], spec["tunables"][f"controller.{n}"]["max"])
           for n in names}
    initial = {n: spec["tunables"][f"controller.{n}"]["initial"] for n in names}
    print(f"{len(sets)} sets x {len(sets[0].omega)} frequencies; load average "
          f"{os.getloadavg()[0]:.2f}")
    _, wall, cpu = timed(lambda: __import__("cvxpy"))
    print(f"import cvxpy: {wall:.2f} s wall, {cpu:.2f} s CPU (once per process)")

    rows = []
    found, wall, cpu = timed(lambda: design(sets, basis, box, initial, m_peak=M_PEAK,
                                            sensitivity_peak=M_S, integrators=1))
    rho = np.array([found.values[n] for n in names])
    rows.append(("convex (cvxpy/Clarabel)", rho, wall, cpu,
                 f"{found.iterations} linearisations, {found.solves} SOCPs"))

    lo = np.log([box[n][0] for n in names])
    hi = np.log([box[n][1] for n in names])
    evaluations = [0]

    def measure(x):
        evaluations[0] += 1
        return evaluate(sets, basis, np.exp(x))

    def objective(x):
        metrics, stable = measure(x)
        value = metrics["bandwidth"]
        return -(value if (stable and value is not None) else 0.0)

    def peaks(x):
        metrics, stable = measure(x)
        if not stable:
            return np.array([10.0, 10.0])
        return np.array([metrics["m_peak"] / M_PEAK - 1, metrics["sensitivity_peak"] / M_S - 1])

    x0 = np.log([initial[n] for n in names])
    evaluations[0] = 0
    slsqp, wall, cpu = timed(lambda: optimize.minimize(
        objective, x0, method="SLSQP", bounds=list(zip(lo, hi)),
        constraints=[{"type": "ineq", "fun": lambda x: -peaks(x)}],
        options={"maxiter": 200}))
    rows.append(("scipy SLSQP", np.exp(slsqp.x), wall, cpu,
                 f"{evaluations[0]} evaluations, {slsqp.message}"))
    evaluations[0] = 0
    de, wall, cpu = timed(lambda: optimize.differential_evolution(
        objective, list(zip(lo, hi)), x0=x0, seed=1, polish=False,
        constraints=optimize.NonlinearConstraint(peaks, -np.inf, 0.0)))
    rows.append(("scipy differential evolution", np.exp(de.x), wall, cpu,
                 f"{evaluations[0]} evaluations, {de.nit} generations"))

    convex_cpu = rows[0][3]
    print(f"{'method':30s} {'bandwidth':>10s} {'M_peak':>8s} {'M_s':>7s} {'stable':>6s} "
          f"{'wall':>7s} {'CPU':>7s} {'CPU/convex':>10s}  gains (kp, ki, kd)")
    for label, rho, wall, cpu, note in rows:
        metrics, stable = evaluate(sets, basis, rho)
        feasible = stable and metrics["m_peak"] <= M_PEAK * (1 + 1e-6) and \
            metrics["sensitivity_peak"] <= M_S * (1 + 1e-6)
        bandwidth = metrics["bandwidth"] if feasible else math.nan
        print(f"{label:30s} {bandwidth:10.4f} {metrics['m_peak']:8.5f} "
              f"{metrics['sensitivity_peak']:7.4f} {str(stable):>6s} {wall:6.2f}s {cpu:6.2f}s "
              f"{cpu / convex_cpu:10.2f}  {', '.join(f'{v:.6g}' for v in rho)}   ({note})")


def side_by_side(revision: str, rounds: int) -> None:
    """This checkout's ``design`` against ``revision``'s, in turn (module docstring)."""
    import dataclasses

    sys.path.insert(0, os.path.join(ROOT, "benchmarks"))
    sys.path.insert(0, os.path.join(ROOT, "tests", "unit"))
    from baseline import baseline_module

    import feedtune.measured.datadriven as new
    import test_datadriven_weighted as weighted

    old = baseline_module(revision, "feedtune/measured/datadriven.py", "baseline_datadriven")
    spec = json.load(open(SPEC_PATH))
    plant = FrequencyResponseData(FrequencyResponseDataParams.model_validate(spec["plant"]))
    sets, basis = plant.sets(), plant.basis()
    box = {n: (spec["tunables"][f"controller.{n}"]["min"], spec["tunables"][f"controller.{n}"]["max"])
           for n in basis.names}
    initial = {n: spec["tunables"][f"controller.{n}"]["initial"] for n in basis.names}
    loads = [new.FrequencySet(name, weighted.OMEGA, weighted.hydraulic(weighted.OMEGA, inertia))
             for name, inertia in (("half", 0.5), ("design", 1.0), ("double", 2.0))]
    w20, w10 = (new.SensitivityWeight(b, 2.0, 1e-3) for b in (20.0, 10.0))
    # the weighted test's start for the bounded design: a controller that meets |W S| ≤ 1
    start = new.design(loads, weighted.PID, weighted.BOX, weighted.INITIAL, m_peak=1.3,
                       objective="weighted_sensitivity", weight=w10, integrators=1).values
    cases = {
        "example: bandwidth, M_peak, M_s": lambda m: m.design(
            sets, basis, box, initial, m_peak=M_PEAK, sensitivity_peak=M_S, integrators=1),
        "three loads: min |W S|, M_peak": lambda m: m.design(
            loads, weighted.PID, weighted.BOX, weighted.INITIAL, objective="weighted_sensitivity",
            weight=w20, m_peak=1.3, integrators=1),
        "three loads: bandwidth, |W S| <= 1": lambda m: m.design(
            loads, weighted.PID, weighted.BOX, start,
            weighted_sensitivity=1.0, weight=w10, m_peak=1.3, integrators=1),
    }
    __import__("cvxpy")
    print(f"new against {revision}'s datadriven.py, {rounds} rounds in turn; load average "
          f"{os.getloadavg()[0]:.2f}")

    def fields(found):
        out = dataclasses.asdict(found)
        del out["solve_time"], out["build_time"]
        return repr(out)

    total = {"new": 0.0, "old": 0.0}
    for label, run in cases.items():
        cpu, results = {"new": [], "old": []}, {}
        for _ in range(rounds):
            for side, module in (("new", new), ("old", old)):
                found, _, seconds = timed(lambda: run(module))
                cpu[side].append(seconds)
                results.setdefault(side, fields(found))
                assert results[side] == fields(found), "a design differs between rounds"
        total["new"] += sum(cpu["new"])
        total["old"] += sum(cpu["old"])
        print(f"  {label:36s} new {min(cpu['new']):.3f} s  old {min(cpu['old']):.3f} s (least "
              f"of {rounds})  new/old {sum(cpu['new']) / sum(cpu['old']):.3f}  every field "
              f"{'equal' if results['new'] == results['old'] else 'DIFFERENT'}")
    print(f"  all: new/old {total['new'] / total['old']:.3f} of CPU")


if __name__ == "__main__":
    import argparse

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", help="git revision of the old datadriven.py")
    parser.add_argument("--rounds", type=int, default=3)
    arguments = parser.parse_args()
    if arguments.baseline:
        side_by_side(arguments.baseline, arguments.rounds)
    else:
        main()
