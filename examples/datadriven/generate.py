"""Write hydraulic-three-loads.json: Bhatia's rotary hydraulic drive measured at three
loads, to tune on the data alone (README, "From a measured file to a tuned axis").

The plant is Bhatia's position per torque-motor volt (examples/bhatia-1971-hydraulic.json,
App. A2/A3), G(s) = (K_s K_q/D_m)/(s (τ s + 1)(s²/ω_n² + 2ξ s/ω_n + 1)), K_s K_q/D_m =
10.0 rad/(s·V), τ = 0.01 s, ω_n = 75 rad/s and ξ = 0.5 at his design load. The load
inertia J_t moves ω_n ∝ 1/√J_t and ξ ∝ √J_t (App. A2): the sets are J_t × 0.5, × 1 and × 2.
Each is "measured" at 500 frequencies from 0.1 to 10 000 rad/s with 1 % complex Gaussian
noise on G (seed 17), as a frequency-response analyser's averaged sweep would give.

Run from the repository: ``python examples/datadriven/generate.py`` (numpy only).
"""

import json
import math
from pathlib import Path

import numpy as np

SEED = 17
POINTS = 500
BAND = (0.1, 1e4)  # rad/s
NOISE = 0.01  # relative, complex Gaussian
GAIN = 0.254 * 5.44225e-06 / 1.38233e-07  # K_s K_q / D_m [rad/(s·V)]
TAU = 0.01  # s
OMEGA_N, XI = 75.0, 0.5
LOADS = {"half-load": 0.5, "design-load": 1.0, "double-load": 2.0}  # J_t factor


def response(omega: np.ndarray, inertia_factor: float) -> np.ndarray:
    """G(jω) [rad/V] at J_t × ``inertia_factor`` (ω_n ∝ J_t^-1/2, ξ ∝ J_t^1/2)."""
    wn, xi = OMEGA_N / math.sqrt(inertia_factor), XI * math.sqrt(inertia_factor)
    s = 1j * omega
    return GAIN / (s * (TAU * s + 1) * (s**2 / wn**2 + 2 * xi * s / wn + 1))


def main() -> None:
    rng = np.random.default_rng(SEED)
    omega = np.logspace(math.log10(BAND[0]), math.log10(BAND[1]), POINTS)
    sets = []
    for name, factor in LOADS.items():
        g = response(omega, factor)
        g = g * (1 + NOISE * (rng.standard_normal(POINTS) + 1j * rng.standard_normal(POINTS)) / math.sqrt(2))
        sets.append({"name": name, "frequency_unit": "rad/s",
                     "frequency": [float(f"{w:.12g}") for w in omega],
                     "real": [float(f"{v:.12g}") for v in g.real],
                     "imag": [float(f"{v:.12g}") for v in g.imag]})
    spec = {
        "name": "hydraulic-three-loads",
        "description": ("Bhatia's rotary hydraulic drive (position per torque-motor volt) "
                        "measured at half, design and double load inertia, 500 frequencies "
                        "each, 1 % noise (examples/datadriven/generate.py, seed 17). A PID with "
                        "its derivative filtered at 2 ms, tuned on the data alone for the "
                        "widest bandwidth with M_peak <= 1.3 and M_s <= 2 on all three sets."),
        "plant": {"type": "frequency_response_data", "input_unit": "V", "output_unit": "rad",
                  "integrators": 1, "unstable_poles": 0, "controller": "pid",
                  "filter_time_constant": 0.002, "sets": sets},
        "tunables": {"controller.kp": {"min": 0.01, "max": 100, "initial": 0.1},
                     "controller.ki": {"min": 0.001, "max": 1000, "initial": 0.01},
                     "controller.kd": {"min": 1e-5, "max": 1, "initial": 1e-4}},
        "objective": [{"metric": "bandwidth", "goal": "maximize"}],
        "constraints": [{"metric": "m_peak", "max": 1.3},
                        {"metric": "sensitivity_peak", "max": 2.0}],
        "solver": {"method": "convex"},
    }
    path = Path(__file__).with_name("hydraulic-three-loads.json")
    path.write_text(json.dumps(spec, indent=1) + "\n")


if __name__ == "__main__":
    main()
