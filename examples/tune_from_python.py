#!/usr/bin/env python
"""Tune a feed drive from Python and plot its step response and Bode diagram.

The drive is Koren's (1979) sampled-data software servo, built in code: a first-order
velocity drive (time constant 20 ms) integrating to position, sampled every 15.625 ms,
with the position gain K free. feedtune picks the K with the least radial error on an
8 mm circle at 40 mm/s while the loop keeps a damping ratio ≥ 0.5. The tuned loop is then
exported to python-control (signals named ``reference``, ``position``, ``error``) and
drawn with matplotlib.

Usage::

    python examples/tune_from_python.py FIGURE.png [--result RESULT.json]
"""

from __future__ import annotations

import argparse

import control
import matplotlib

matplotlib.use("Agg")  # files only, no window
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import feedtune  # noqa: E402


def build_spec() -> feedtune.Spec:
    """The tuning problem, in SI units: gains [1/s], periods and time constants [s],
    lengths [m], velocities [m/s]."""
    return feedtune.Spec.model_validate({
        "name": "sampled-servo-from-python",
        "plant": {"type": "software_servo", "technique": "sampled_data",
                  "time_constant": 0.02, "blu": 5e-6, "max_velocity": 0.04},
        "tunables": {"position_gain": {"min": 1, "max": 200},
                     "sampling_period": {"value": 0.015625}},
        "objective": [{"metric": "radial_error", "radius": 0.008, "feed": 0.04}],
        "constraints": [{"metric": "damping_ratio", "min": 0.5}],
        "solver": {"multistart": 4},
    })


def plot(result: feedtune.Result, path: str) -> None:
    """Step response and Bode diagram of the tuned loop, into ``path`` (format by suffix)."""
    systems = result.to_control()
    unit = systems.position_unit
    step = control.step_response(systems.closed_loop, T=np.arange(0, 0.4, systems.dt))
    omega = np.geomspace(0.1, 0.99 * np.pi / systems.dt, 400)  # up to Nyquist [rad/s]
    response = systems.open_loop.frequency_response(omega)
    closed = systems.closed_loop.frequency_response(omega)

    figure, (ax_step, ax_mag, ax_phase) = plt.subplots(3, 1, figsize=(7, 9))
    ax_step.step(step.time, step.outputs, where="post", label="position")
    ax_step.axhline(1, color="grey", linestyle="--", linewidth=0.8, label="reference")
    ax_step.set(xlabel="time [s]", ylabel=f"position [{unit}]",
                title=f"{result.name}: K = {result.values['position_gain']:.4g} "
                      f"{result.units['position_gain']}, unit step")
    ax_step.legend()
    ax_mag.semilogx(omega, 20 * np.log10(response.magnitude), label="open loop L")
    ax_mag.semilogx(omega, 20 * np.log10(closed.magnitude), label="closed loop T")
    ax_mag.set(ylabel="magnitude [dB]")
    ax_mag.legend()
    ax_phase.semilogx(omega, np.degrees(np.unwrap(response.phase)), label="open loop L")
    ax_phase.semilogx(omega, np.degrees(np.unwrap(closed.phase)), label="closed loop T")
    ax_phase.set(xlabel="frequency [rad/s]", ylabel="phase [deg]")
    for ax in (ax_step, ax_mag, ax_phase):
        ax.grid(True, which="both", linewidth=0.3)
    figure.tight_layout()
    figure.savefig(path)
    plt.close(figure)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("figure", help="Write the plot here (.png, .svg or .pdf)")
    parser.add_argument("--result", help="Also save the result JSON here (as `feedtune tune -o`)")
    args = parser.parse_args()

    result = feedtune.tune(build_spec())
    print(result.summary())
    if not result.success:
        raise SystemExit(f"not tuned: {result.status}")
    gain_margin, phase_margin, *_ = control.stability_margins(result.to_control().open_loop)
    print(f"python-control: gain margin {gain_margin:.3g} [1], phase margin "
          f"{phase_margin:.3g} [deg]")
    plot(result, args.figure)
    print(f"wrote {args.figure}")
    if args.result:
        print(f"wrote {result.save(args.result)}")


if __name__ == "__main__":
    main()
