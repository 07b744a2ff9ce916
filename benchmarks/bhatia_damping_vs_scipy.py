#!/usr/bin/env python
"""Bhatia's hydraulic drive, all eight tunables free, widest bandwidth with ζ_min ≥ 0.3:
feedtune (the factor form of the pole region) against scipy, side by side.

The spec is ``examples/bhatia-1971-hydraulic.json`` (C_v ≥ 80 1/s, sensitivity ≥ 1000 1/s,
M_peak ≤ 1.3, both loops stable) plus ``pole_damping`` ≥ 0.3: every closed-loop pole's
damping ratio −Re p/|p| at least 0.3 (MATLAB's ``TuningGoal.Poles`` MinDamping). Bhatia's
hand design has ζ_min = 0.134 and the unbounded optimum (689.8 rad/s) less, so the bound
binds.

Solved by feedtune (one start, Bhatia's design) and by scipy ``differential_evolution`` and
SLSQP on the independent numpy model of ``benchmarks/bhatia_vs_scipy.py`` (no feedtune
code), with one more constraint row ζ_min/0.3 − 1 ≥ 0 from ``numpy.roots`` of the closed
position loop. Every answer is re-evaluated by that file's dense verification plus
ζ_min from ``numpy.roots``; feasible = both loops stable and every bound within 1e-6
relative. Times are CPU (``time.process_time``) and wall, with the load average.
"""

from __future__ import annotations

import argparse
import copy
import math
import os
import sys
import time

import numpy as np
from scipy import optimize

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bhatia_vs_scipy import (DE_POPSIZE, DE_SEED, FEAS_TOL, NAMES, SLSQP_FTOL,  # noqa: E402
                             SLSQP_MAXITER, Functions, Model, load_spec, problem_data,
                             starting_points, verify)

ZETA = 0.3  # the bound [1]


def damping(model: Model, x) -> float:
    """ζ_min = min −Re p/|p| over numpy.roots of the closed position loop [1]."""
    roots = np.roots(model.polynomials(x)[1])
    return float(np.min(-roots.real / np.abs(roots)))


class DampedFunctions(Functions):
    """bhatia_vs_scipy's objective and constraints, plus ζ_min/ZETA − 1 ≥ 0."""

    def constraints(self, z) -> np.ndarray:
        return np.append(super().constraints(z), damping(self.model, np.exp(z)) / ZETA - 1)


def timed(fn):
    """(result, CPU seconds, wall seconds) of fn()."""
    cpu, wall = time.process_time(), time.perf_counter()
    out = fn()
    return out, time.process_time() - cpu, time.perf_counter() - wall


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--de-maxiter", type=int, default=200, help="DE generations")
    parser.add_argument("--starts", type=int, default=8, help="SLSQP starts")
    args = parser.parse_args(argv)

    spec = load_spec()
    plant, bounds, initial, limits, _ = problem_data(spec)
    model = Model(plant)
    scale = verify(model, initial).bandwidth
    bounds_z = [(math.log(lo), math.log(hi)) for lo, hi in bounds]
    damped = copy.deepcopy(spec)
    damped["constraints"].append({"metric": "pole_damping", "min": ZETA})
    print(f"load average at start {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs")
    print(f"Bhatia's hand design: bandwidth {scale:.3f} rad/s, "
          f"ζ_min {damping(model, initial):.4f}")

    from feedtune.problem import tune
    from feedtune.schema.spec import parse_spec

    result, cpu, wall = timed(lambda: tune(parse_spec(copy.deepcopy(damped))))
    rows = [("feedtune (IPOPT, factor form)", np.array([result.tuned[n].value for n in NAMES]),
             cpu, wall, f"{result.solver.iterations} IPOPT iterations, {result.status}")]

    def de():
        fun = DampedFunctions(model, limits, scale)
        res = optimize.differential_evolution(
            fun.objective, bounds_z, constraints=fun.nonlinear_constraint(), seed=DE_SEED,
            popsize=DE_POPSIZE, maxiter=args.de_maxiter, polish=False, x0=np.log(initial))
        return res, fun.evaluations

    (res, evaluations), cpu, wall = timed(de)
    rows.append(("differential_evolution", np.exp(res.x), cpu, wall,
                 f"{res.nit} generations, {evaluations} evaluations: {res.message}"))

    def slsqp():
        fun = DampedFunctions(model, limits, scale)
        out = [optimize.minimize(fun.objective, z0, method="SLSQP", bounds=bounds_z,
                                 constraints=[fun.nonlinear_constraint()],
                                 options={"ftol": SLSQP_FTOL, "maxiter": SLSQP_MAXITER})
               for z0 in starting_points(bounds, initial, args.starts)]
        feasible = [r for r in out if np.all(fun.constraints(r.x) >= -FEAS_TOL)]
        return min(feasible or out, key=lambda r: r.fun), len(feasible), len(out)

    (best, feasible, count), cpu, wall = timed(slsqp)
    rows.append((f"SLSQP, {count} starts", np.exp(best.x), cpu, wall,
                 f"{feasible}/{count} model-feasible"))

    print(f"max bandwidth s.t. the bundled bounds and ζ_min ≥ {ZETA}; verified by the dense "
          "grid of bhatia_vs_scipy.py and numpy.roots")
    print(f"{'method':<32} {'CPU s':>7} {'wall s':>7} {'bandwidth':>10} {'M_peak':>7} "
          f"{'ζ_min':>9} {'feas.':>5}  note")
    for name, x, cpu, wall, note in rows:
        m = verify(model, x)
        zeta = damping(model, x)
        ok = m.feasible(limits) and zeta >= ZETA * (1 - FEAS_TOL)
        print(f"{name:<32} {cpu:7.2f} {wall:7.2f} {m.bandwidth:10.3f} {m.m_peak:7.4f} "
              f"{zeta:9.6f} {'yes' if ok else 'NO':>5}  {note}")
    print(f"load average at end {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
