"""Seeded generators of realistic specs, one per plant family, in machine-tool ranges.

Used by tests/batch/test_realistic_specs.py to prove the validator raises no false alarm
on what users tune (feedtune issue 14: 24 of 50 ball-screw variants failed a batch only
because radial errors of 1e-15 m were compared relatively). Each function takes a numpy
Generator and an index and returns a spec dict.
"""

from __future__ import annotations

import copy
import json
from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parents[1] / "data"
EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def _r(value: float, digits: int = 4) -> float:
    return float(f"{value:.{digits}g}")


def ball_screw(rng: np.random.Generator, i: int) -> dict:
    """The issue's family: a software servo sampling a ball-screw axis (Koren's sampled
    data), radial error on 5 and 20 mm circles at a contouring feed, damping and counter
    constraints. τ 5–40 ms, BLU 0.5–10 µm, V_m 5–30 m/min, feed 1–10 m/min, 16-bit counter."""
    feed = _r(rng.uniform(1, 10) / 60)
    return {"name": f"ball-screw-{i:03d}",
            "plant": {"type": "software_servo", "technique": "sampled_data",
                      "time_constant": _r(rng.uniform(0.005, 0.04)),
                      "blu": float(rng.choice([0.5e-6, 1e-6, 2e-6, 5e-6, 10e-6])),
                      "max_velocity": _r(rng.uniform(5, 30) / 60), "counter_bits": 16},
            "tunables": {"position_gain": {"min": 1, "max": 300},
                         "sampling_period": {"min": 0.0005, "max": 0.01}},
            "objective": [{"metric": "radial_error", "radius": 0.005, "feed": feed},
                          {"metric": "radial_error", "radius": 0.02, "feed": feed}],
            "constraints": [{"metric": "damping_ratio", "min": _r(rng.uniform(0.5, 0.7), 3)},
                            {"metric": "counter_utilisation", "max": 1}],
            "solver": {"multistart": 2}}


def reference_pulse(rng: np.random.Generator, i: int) -> dict:
    """Koren's reference-pulse servo (continuous loop): radial error on a 10 mm circle,
    damping at least 0.5; τ 5–40 ms, BLU 1–10 µm, V_m 1–5 m/min (f_m ≤ 80 kHz, eq 2)."""
    return {"name": f"reference-pulse-{i:03d}",
            "plant": {"type": "software_servo", "technique": "reference_pulse",
                      "time_constant": _r(rng.uniform(0.005, 0.04)),
                      "blu": float(rng.choice([1e-6, 2e-6, 5e-6, 10e-6])),
                      "max_velocity": _r(rng.uniform(1, 5) / 60)},
            "tunables": {"position_gain": {"min": 1, "max": 300}},
            "objective": [{"metric": "radial_error", "radius": 0.01,
                           "feed": _r(rng.uniform(0.5, 2) / 60)}],
            "constraints": [{"metric": "damping_ratio", "min": 0.5}],
            "solver": {"multistart": 2}}


def sato(rng: np.random.Generator, i: int, model: str) -> dict:
    """Sato's interpolated software servo (one sample of computation delay): least surface
    roughness on a 20–80 mm circle at 20–100 mm/s, decrease in radius ≤ 10 µm, q ≥ 2;
    Δt_p ≥ 2 ms, T ≥ 10 ms, an ideal drive or τ 2–10 ms."""
    radius, feed = _r(rng.uniform(0.02, 0.08)), _r(rng.uniform(0.02, 0.1))
    tau = None if rng.uniform() < 0.5 else _r(rng.uniform(0.002, 0.01))
    return {"name": f"sato-{model}-{i:03d}",
            "plant": {"type": "software_servo", "technique": "sampled_data",
                      "time_constant": tau, "computation_delay": 1, "model": model,
                      "interpolation": "linear"},
            "tunables": {"position_gain": {"min": 5, "max": 200},
                         "sampling_period": {"min": 0.002, "max": 0.02},
                         "reference_interval": {"min": 0.01, "max": 0.5}},
            "objective": [{"metric": "surface_roughness", "radius": radius, "feed": feed}],
            "constraints": [{"metric": "radius_decrease", "radius": radius, "feed": feed,
                             "max": 1e-5},
                            {"metric": "interpolation_ratio", "min": 2}],
            "solver": {"multistart": 2}}


def pulse_generator(rng: np.random.Generator, i: int) -> dict:
    """Tian's V-F pulse generator: a 2–5 rad step, the motor's acceleration limit
    100–200 krad/s², fastest settling within it (a short seeded search)."""
    spec = json.loads((EXAMPLES / "tian-vf-pulse.json").read_text())
    limit = _r(rng.uniform(1e5, 2e5))
    spec["name"] = f"pulse-generator-{i:03d}"
    spec["plant"]["amplitude"] = _r(rng.uniform(2, 5))
    spec["plant"]["motor_characteristic"] = [[0, limit], [140000, limit]]
    spec["solver"] = {"multistart": 1, "max_iter": 8}
    return spec


def bhatia_copy(rng: np.random.Generator, i: int, name: str) -> dict:
    """A perturbed copy of a stored Bhatia result (tuning it takes tens of seconds): every
    numeric plant parameter and every tuned value moved by up to ±5 % and fixed, so that
    tuning evaluates every metric at a design near the optimum; the constraints dropped
    (the copy need not meet them)."""
    result = json.loads((DATA / f"{name}.result.json").read_text())
    spec = copy.deepcopy(result["spec"])
    spec["name"] = f"{name}-copy-{i:03d}"
    for key, value in spec["plant"].items():
        if isinstance(value, float) and value > 0:
            spec["plant"][key] = _r(value * rng.uniform(0.95, 1.05), 6)
    spec["tunables"] = {key: {"value": _r(t["value"] * rng.uniform(0.95, 1.05), 6)}
                        for key, t in result["tuned"].items()}
    spec["constraints"] = []
    spec["solver"] = {"multistart": 1}
    return spec


def realistic_specs(seed: int, ball_screws: int) -> list[dict]:
    """``ball_screws`` ball-screw variants and two of every other family, from ``seed``."""
    rng = np.random.default_rng(seed)
    specs = [ball_screw(rng, i) for i in range(ball_screws)]
    specs += [reference_pulse(rng, i) for i in range(2)]
    specs += [sato(rng, i, "exact") for i in range(2)]
    specs += [sato(rng, i, "pade") for i in range(2)]
    specs += [pulse_generator(rng, i) for i in range(2)]
    specs += [bhatia_copy(rng, i, "bhatia-1971-hydraulic") for i in range(1)]
    specs += [bhatia_copy(rng, i, "ward-leonard-feed-drive") for i in range(1)]
    return specs
