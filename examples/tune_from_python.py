#!/usr/bin/env python
"""Tune a user-defined feed drive from Python and plot its step response and Bode diagram.

The drive is a ball-screw axis as its user writes it (the numbers of
``examples/user-defined-drive.json``): motor torque [N·m] to motor angle [rad], a two-mass
model with its first mode at 1732 rad/s and a 0.2 ms dead time, built in code as a
transfer function. A PI velocity loop (integral time fixed at 10 ms) sits inside a P
position loop with 50 % velocity feed-forward; feedtune picks the two gains for the widest
closed-loop bandwidth with M_peak ≤ 1.3 and a phase margin of at least 45°. The tuned loop
is then exported to python-control (signals named ``reference``, ``position``, ``error``;
the dead time as its Padé approximant) and drawn with matplotlib.

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
    """The tuning problem, in SI units: inertias [kg·m²], stiffness [N·m/rad] and damping
    [N·m·s/rad] inside the transfer function's coefficients, dead time and integral time
    [s], position gain [1/s], velocity gain [N·m·s/rad]."""
    j_m, j_l, k, c = 1e-3, 2e-3, 2000.0, 0.0462  # motor, load, coupling, coupling damping
    return feedtune.Spec.model_validate({
        "name": "user-drive-from-python",
        "plant": {"type": "linear",
                  "model": {"type": "transfer_function",  # θ_m/T of the two-mass drive
                            "numerator": [j_l, c, k],
                            "denominator": [j_m * j_l, c * (j_m + j_l), k * (j_m + j_l), 0, 0]},
                  "input_unit": "N·m", "output_unit": "rad", "dead_time": 2e-4,
                  "velocity_controller": "pi", "position_controller": "p",
                  "velocity_feedforward": 0.5},
        "tunables": {"position_controller.kp": {"min": 10, "max": 1000, "initial": 50},
                     "velocity_controller.kp": {"min": 0.01, "max": 10, "initial": 0.3},
                     "velocity_controller.ti": {"value": 0.01}},
        "objective": [{"metric": "bandwidth", "goal": "maximize"}],
        "constraints": [{"metric": "m_peak", "max": 1.3},
                        {"metric": "phase_margin", "min": 45}],
        "solver": {"multistart": 1},
    })


def plot(result: feedtune.Result, path: str) -> None:
    """Step response and Bode diagram of the tuned loop, into ``path`` (format by suffix)."""
    systems = result.to_control()
    unit = systems.position_unit
    if systems.dt:  # a sampled loop: on its samples, up to the Nyquist frequency
        step = control.step_response(systems.closed_loop, T=np.arange(0, 0.4, systems.dt))
        omega = np.geomspace(0.1, 0.99 * np.pi / systems.dt, 400)  # [rad/s]
    else:
        step = control.step_response(systems.closed_loop, T=np.linspace(0, 0.05, 2001))
        omega = np.geomspace(1.0, 1e5, 400)  # [rad/s]
    response = systems.open_loop.frequency_response(omega)
    closed = systems.closed_loop.frequency_response(omega)

    figure, (ax_step, ax_mag, ax_phase) = plt.subplots(3, 1, figsize=(7, 9))
    ax_step.plot(step.time, step.outputs, drawstyle="steps-post" if systems.dt else "default",
                 label="position")
    ax_step.axhline(1, color="grey", linestyle="--", linewidth=0.8, label="reference")
    ax_step.set(xlabel="time [s]", ylabel=f"position [{unit}]",
                title=f"{result.name}, unit step\n" + ", ".join(
                    f"{name} = {value:.4g} {result.units[name]}"
                    for name, value in result.values.items()))
    ax_step.title.set_fontsize(9)
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
