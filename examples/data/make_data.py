"""Make the bundled measurement examples: data simulated from known drives, with 1 % noise.

Run ``python examples/data/make_data.py`` to write the files next to this script again
(the same bytes: the seed is fixed). The drives are the bundled examples' plants, so an
identification can be checked against the truth (tests/unit/measured/). The simulation is
python-control's (c2d with a zero-order hold, forced_response, evalfr), not feedtune's own.

Noise: a time series gets white Gaussian noise of 1 % of its output's RMS; a frequency
response complex Gaussian noise of 1 % of |G| at each frequency (0.71 % on each of the
real and imaginary parts).
"""

from __future__ import annotations

import json
from pathlib import Path

import control
import numpy as np

HERE = Path(__file__).resolve().parent
EXAMPLES = HERE.parent
SEED = 20261127
NOISE = 0.01


def plant_block(example: str) -> dict:
    """The plant block of a bundled example spec."""
    return json.loads((EXAMPLES / f"{example}.json").read_text())["plant"]


def velocity_transfer(plant: dict, velocity_gain: float | None = None):
    """The drive's velocity per command, (numerator, denominator) highest power first, and
    its dead time [s]: from the plant classes (hydraulic, Ward-Leonard), Koren's
    K_m/(1 + τs) (software servo, K_m = ``velocity_gain``), or the linear plant's model
    times s."""
    from feedtune.plants import PLANTS

    kind = plant["type"]
    if kind == "software_servo":
        return [velocity_gain], [plant["time_constant"], 1.0], 0.0
    if kind == "linear":
        num, den = plant["model"]["numerator"], plant["model"]["denominator"]
        return list(num) + [0.0], list(den), plant.get("dead_time", 0.0)  # s·P(s)
    drive = PLANTS[kind](PLANTS[kind].Params.model_validate(plant))
    num, d1, d2 = drive.velocity_per_volt()
    return list(num), list(np.polymul(d1, d2)), 0.0


def frequency_response(num, den, dead_time, omega, derivative, rng, noise=NOISE):
    """(s^derivative/s)·(num/den)(jω)·e^{−jωθ} with complex noise of ``noise``·|G|:
    derivative 1 the velocity response, 0 the position response."""
    sys = control.tf(num, np.polymul(den, [1.0, 0.0]) if derivative == 0 else den)
    g = np.array([complex(sys(1j * w)) for w in omega]) * np.exp(-1j * omega * dead_time)
    return g + noise * np.abs(g) * (rng.standard_normal(len(g))
                                    + 1j * rng.standard_normal(len(g))) / np.sqrt(2)


def time_response(num, den, dead_samples, command, period, derivative, rng, noise=NOISE):
    """The sampled response to ``command`` held between samples (c2d, zero-order hold),
    delayed by whole samples, plus white noise of ``noise``·RMS of the output."""
    sys = control.tf(num, np.polymul(den, [1.0, 0.0]) if derivative == 0 else den)
    delayed = np.concatenate([np.zeros(dead_samples), command])[:len(command)]
    y = control.forced_response(control.c2d(sys, period, "zoh"), U=delayed).outputs
    return y + noise * np.sqrt(np.mean(y ** 2)) * rng.standard_normal(len(y))


def random_steps(count, hold, rng):
    """±1 held for ``hold`` samples at a time, ``count`` samples: a random binary signal."""
    return np.repeat(rng.choice([-1.0, 1.0], -(-count // hold)), hold)[:count]


def csv(header: str, columns, comment: str) -> str:
    lines = [f"# {line}" for line in comment.splitlines()] + [header]
    lines += [",".join(f"{v:.10g}" for v in row) for row in np.column_stack(columns)]
    return "\n".join(lines) + "\n"


#: software servo: Koren's τ = 20 ms with a drive gain K_m [m/(s·V)] chosen here
SERVO_VELOCITY_GAIN = 0.05


def make() -> dict[str, str]:
    """{file name: text} of every example data file."""
    rng = np.random.default_rng(SEED)
    files = {}

    num, den, _ = velocity_transfer(plant_block("koren-1979-reference-pulse"),
                                    SERVO_VELOCITY_GAIN)
    period, count = 1e-3, 2000
    t = np.arange(count) * period
    u = np.where((t >= 0.1) & (t < 1.1), 1.0, 0.0)  # a 1 V pulse of 1 s
    y = time_response(num, den, 0, u, period, 0, rng)
    files["software-servo-step.csv"] = csv(
        "time[s],command[V],position[m]", [t, u, y],
        f"Koren's drive, tau = 0.02 s, K_m = {SERVO_VELOCITY_GAIN} m/(s V): a 1 V pulse, "
        "position, 1 % noise (make_data.py)")

    num, den, _ = velocity_transfer(plant_block("bhatia-1971-hydraulic"))
    omega = np.logspace(0, 3, 400)
    for run in (1, 2):
        g = frequency_response(num, den, 0.0, omega, 1, rng)
        files[f"hydraulic-frf-{run}.csv"] = csv(
            "frequency[Hz],magnitude[rad/s/V],phase[deg]",
            [omega / (2 * np.pi), np.abs(g), np.degrees(np.unwrap(np.angle(g)))],
            f"Bhatia's hydraulic drive (examples/bhatia-1971-hydraulic.json): velocity per "
            f"torque-motor volt, run {run}, 1 % noise (make_data.py)")

    num, den, _ = velocity_transfer(plant_block("ward-leonard-feed-drive"))
    period, count = 0.01, 3000
    u = random_steps(count, 50, rng)
    y = time_response(num, den, 0, u, period, 1, rng)
    files["ward-leonard-prbs.csv"] = csv(
        "time[s],command[V],velocity[rad/s]", [np.arange(count) * period, u, y],
        "Ward-Leonard drive (examples/ward-leonard-feed-drive.json): random binary field "
        "voltage, motor velocity, 1 % noise (make_data.py)")

    plant = plant_block("user-defined-drive")
    num, den, dead_time = velocity_transfer(plant)
    omega = np.logspace(np.log10(2 * np.pi * 5), np.log10(2 * np.pi * 2000), 500)
    g = frequency_response(num[:-1], den[:-1], dead_time, omega, 0, rng)  # position: P(s)
    files["two-mass-frf.json"] = json.dumps({
        "description": "The two-mass axis of examples/user-defined-drive.json (torque to "
                       "motor angle, 0.2 ms dead time), 1 % noise (make_data.py)",
        "units": {"frequency": "rad/s", "real": "rad/N·m", "imag": "rad/N·m"},
        "frequency": [float(f"{w:.10g}") for w in omega],
        "real": [float(f"{v:.10g}") for v in g.real],
        "imag": [float(f"{v:.10g}") for v in g.imag]}, indent=1) + "\n"
    return files


if __name__ == "__main__":
    for name, text in make().items():
        (HERE / name).write_text(text)
        print(f"wrote {HERE / name}")
