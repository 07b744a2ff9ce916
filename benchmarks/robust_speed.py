#!/usr/bin/env python
"""Issue 17's robust-tuning benchmark: time against the number of scenarios, feedtune's
scenario NLP side by side with scipy's differential evolution over the worst case.

The problem: the README's Ward-Leonard drive (Bhatia App. B, Palm's machine data),
uncompensated, P position and velocity gains free (1-1000), the widest bandwidth of the
nominal drive with M_peak ≤ 1.3 for every load inertia J_t in 10 kg·m² ± 50 %. Its
worst inertia lies between the range's ends (≈ 6.2 kg·m²), so the corners alone are not
enough and the worst-case refinement matters.

For each scenario count N = 3 + interior samples (nominal, the two ends, seeded
Latin-hypercube points: :func:`feedtune.robust.initial_scenarios`) it runs

* feedtune on the N scenarios alone (``robust.max_rounds`` 1: one NLP, N loops);
* feedtune with the worst-case refinement (``max_rounds`` 8, the default: rounds until no
  inertia in the range violates the bound by more than 1e-6 of it);
* scipy ``differential_evolution`` on a numpy model written here (no feedtune code) over
  the same N scenarios: maximise the nominal bandwidth subject to max_k M_peak_k ≤ 1.3
  and every scenario's loop stable (one ``NonlinearConstraint``), seed 1, scipy's default
  population and tolerance, over ln K'_p, ln K'_v.

Every answer is judged by the same evaluation, feedtune's validator
(``feedtune/validate/ward_leonard.py``, its own state-space model): the nominal bandwidth
and the largest M_peak over the N scenarios and over a 241-point grid of the range. Times
are process CPU and wall clock, each run in this one process, one after the other; the
load average is printed.

Loop algebra (Fig 18, unity feedback): G = n_g/d_g, n_g = k_t K'_c/R_fg,
d_g = (τ_fg s + 1)((L_a s + R_a)(J_t s + B_m) + k_t k_b); T = K'_p K'_v n_g/char,
char = s(d_g + K'_v n_g) + K'_p K'_v n_g. Bandwidth: the lowest ω with |T|² ≤ ½ (T(0) = 1),
refined by brentq; M_peak: the grid's largest |T| refined by bounded Brent.
"""

from __future__ import annotations

import argparse
import copy
import json
import math
import os
import time

import numpy as np
from scipy import optimize

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SPEC_PATH = os.path.join(ROOT, "examples", "ward-leonard-feed-drive.json")
M_PEAK = 1.3
J_NOMINAL, J_SPREAD = 10.0, 0.5  # [kg·m²], ± 50 %
GRID = 241  # the validator's re-check over the range [points]
OMEGA = np.logspace(-3, 3, 3000)  # [rad/s]: the numpy model's grid (loop corners 0.01-100)
DE_SEED = 1


def spec(interior: int, rounds: int) -> dict:
    """The benchmark's spec: ``interior`` Latin-hypercube samples, ``rounds`` at most."""
    data = json.load(open(SPEC_PATH))
    data["plant"].update(velocity_compensator="none", position_compensator="none",
                         inertia={"nominal": J_NOMINAL, "tolerance_percent": 100 * J_SPREAD})
    data["tunables"] = {"position_gain": {"min": 1, "max": 1000, "initial": 20},
                        "velocity_gain": {"min": 1, "max": 1000, "initial": 100}}
    data["constraints"] = [{"metric": "m_peak", "max": M_PEAK}]
    data["robust"] = {"interior_samples": interior, "max_rounds": rounds}
    return data


# -- numpy model (no feedtune code) --------------------------------------------------------

def closed_loop(plant: dict, inertia: float, kp: float, kv: float):
    """(numerator, characteristic polynomial) of T = θ/θ_i, highest power first."""
    rfg = plant["generator_field_resistance"]
    n_g = plant["torque_constant"] * plant["generator_gain"] / rfg
    motor = np.polyadd(np.polymul([plant["armature_inductance"], plant["armature_resistance"]],
                                  [inertia, plant["viscous_damping"]]),
                       [plant["torque_constant"] * plant["back_emf_constant"]])
    d_g = np.polymul([plant["generator_field_inductance"] / rfg, 1.0], motor)
    char = np.polyadd(np.polymul([1.0, 0.0], np.polyadd(d_g, [kv * n_g])), [kp * kv * n_g])
    return np.array([kp * kv * n_g]), char


def magnitude(num, den, w):
    s = 1j * np.asarray(w)
    return np.abs(np.polyval(num, s) / np.polyval(den, s))


def m_peak(num, den) -> float:
    mags = magnitude(num, den, OMEGA)
    i = int(np.argmax(mags))
    if i in (0, len(OMEGA) - 1):
        return float(mags[i])
    res = optimize.minimize_scalar(lambda lw: -magnitude(num, den, math.exp(lw)),
                                   bounds=(math.log(OMEGA[i - 1]), math.log(OMEGA[i + 1])),
                                   method="bounded", options={"xatol": 1e-10})
    return float(max(-res.fun, mags[i]))


def bandwidth(num, den) -> float:
    mags2 = magnitude(num, den, OMEGA) ** 2 - 0.5
    below = np.nonzero(mags2 <= 0)[0]
    if not len(below) or below[0] == 0:
        return 0.0
    i = below[0]
    return optimize.brentq(lambda w: magnitude(num, den, w) ** 2 - 0.5, OMEGA[i - 1], OMEGA[i],
                           xtol=1e-12)


def de_solve(plant: dict, inertias: list[float]) -> tuple[dict, int]:
    """scipy DE over ln K'_p, ln K'_v: the nominal bandwidth, M_peak ≤ 1.3 and stability
    at every one of ``inertias``; (the answer, function evaluations)."""
    def loops(z):
        kp, kv = np.exp(z)
        return [closed_loop(plant, j, kp, kv) for j in inertias]

    def objective(z):
        num, den = closed_loop(plant, J_NOMINAL, *np.exp(z))
        return -bandwidth(num, den)

    def constraint(z):
        worst = []
        for num, den in loops(z):
            abscissa = max(np.roots(den).real)
            worst.append(m_peak(num, den) if abscissa < 0 else 1e3 + abscissa)
        return max(worst)

    bounds = [(0.0, math.log(1000.0))] * 2
    res = optimize.differential_evolution(
        objective, bounds, constraints=optimize.NonlinearConstraint(constraint, -np.inf, M_PEAK),
        seed=DE_SEED, x0=np.log([20.0, 100.0]), polish=False)
    kp, kv = np.exp(res.x)
    return {"position_gain": float(kp), "velocity_gain": float(kv)}, int(res.nfev)


# -- one evaluation for every answer ------------------------------------------------------

def judge(plant: dict, tuned: dict, inertias: list[float]) -> dict:
    """feedtune's validator on ``tuned``: nominal bandwidth [rad/s], the largest M_peak over
    ``inertias`` and over the dense grid of the range."""
    from feedtune.validate.models import model_for

    def at(j):
        return model_for({**plant, "inertia": j}, tuned)

    grid = np.linspace(J_NOMINAL * (1 - J_SPREAD), J_NOMINAL * (1 + J_SPREAD), GRID)
    return {"bandwidth": at(J_NOMINAL).bandwidth(),
            "m_peak_scenarios": max(at(j).m_peak() for j in inertias),
            "m_peak_range": max(at(j).m_peak() for j in grid)}


def timed(fn):
    cpu, wall = time.process_time(), time.perf_counter()
    out = fn()
    return out, time.process_time() - cpu, time.perf_counter() - wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--interior", type=int, nargs="+", default=[0, 2, 6, 14],
                        help="interior samples per run (N = 3 + this scenarios) [count]")
    args = parser.parse_args()
    from feedtune.problem import tune
    from feedtune.robust import initial_scenarios
    from feedtune.schema.spec import parse_spec

    print(f"load average at start: {os.getloadavg()}")
    rows = []
    for interior in args.interior:
        one = parse_spec(spec(interior, 1))
        plant = one.plant.model_dump(mode="json")
        inertias = [s.values["inertia"] for s in initial_scenarios(one.robust,
                                                                   {"inertia": J_NOMINAL})]
        sampled, cpu_s, wall_s = timed(lambda: tune(copy.deepcopy(one)))
        refined, cpu_r, wall_r = timed(lambda: tune(parse_spec(spec(interior, 8))))
        (de, nfev), cpu_d, wall_d = timed(lambda: de_solve(plant, inertias))
        for name, tuned, cpu, wall, extra in (
                ("feedtune, N scenarios", {k: t.value for k, t in sampled.tuned.items()},
                 cpu_s, wall_s, f"1 round, {sampled.robust.rounds} NLP"),
                ("feedtune, refined", {k: t.value for k, t in refined.tuned.items()},
                 cpu_r, wall_r, f"{refined.robust.rounds} rounds, "
                                f"{len(refined.robust.scenarios)} scenarios at the end"),
                ("scipy DE, N scenarios", de, cpu_d, wall_d, f"{nfev} evaluations")):
            quality = judge(plant, tuned, inertias)
            rows.append((len(inertias), name, cpu, wall, quality, extra))
            print(f"N={len(inertias):2d} {name:24s} cpu {cpu:7.2f} s  wall {wall:7.2f} s  "
                  f"bandwidth {quality['bandwidth']:.5f} rad/s  M_peak scenarios "
                  f"{quality['m_peak_scenarios']:.6f}  range {quality['m_peak_range']:.6f}  "
                  f"({extra})", flush=True)
        print(f"N={len(inertias):2d} CPU ratio DE / feedtune (N scenarios) "
              f"{cpu_d / cpu_s:.1f}, DE / feedtune (refined) {cpu_d / cpu_r:.1f}", flush=True)
    print(f"load average at end: {os.getloadavg()}")


if __name__ == "__main__":
    main()
