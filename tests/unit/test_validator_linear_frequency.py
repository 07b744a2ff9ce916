"""The validator's linear drive in the frequency domain (feedtune/validate/linear.py): its
signal equations σ = M σ + Q, solved by elimination along the loop cut at the drive's
output (one division by the return difference per frequency), give the solution of the
dense 9 × 9 system (I − M) σ = Q by LU, in every shape of the loop: a cascade or not,
a position or a velocity output, a transfer-function or a state-space drive, a dead
time or none, the loop closed or opened at the position feedback, with and without
feed-forward.

Tolerance: 1e-12 of the response's own magnitude at each frequency: both are a few dozen
rounded operations on the same gains (the refined dense solve and the elimination agree
within 7.2e-16 over these 48 cases, measured).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import tf2ss

from feedtune.validate.linear import SIGNALS, LinearModel

#: the README's two-mass ball screw, motor torque → motor angle (examples/user-defined-drive.json)
NUMERATOR = [0.002, 0.0462, 2000.0]
DENOMINATOR = [2e-06, 0.0001386, 6.0, 0.0, 0.0]
REL = 1e-12

CASCADE = {"velocity_controller": "pi", "position_controller": "p"}
PID_NOTCH = {"velocity_controller": "none", "position_controller": "pid",
             "notch": "position_loop"}
TUNED = {"position_controller.kp": 50.0, "velocity_controller.kp": 0.3,
         "velocity_controller.ti": 0.01}
TUNED_PID = {"position_controller.kp": 40.0, "position_controller.ti": 0.05,
             "position_controller.td": 0.004, "position_controller.n": 10.0,
             "notch.frequency": 1700.0, "notch.width": 0.15, "notch.depth": 0.2}


def _drive(kind: str) -> tuple[dict, str]:
    """(model, output unit) of the ball screw: its angle, its speed, or its angle as a
    state-space model."""
    if kind == "angle":
        return {"type": "transfer_function", "numerator": NUMERATOR,
                "denominator": DENOMINATOR}, "rad"
    if kind == "speed":
        return {"type": "transfer_function", "numerator": NUMERATOR,
                "denominator": DENOMINATOR[:-1]}, "rad/s"
    a, b, c, d = tf2ss(NUMERATOR, DENOMINATOR)
    return {"type": "state_space", "a": a.tolist(), "b": b.tolist(), "c": c.tolist(),
            "d": d.tolist()}, "rad"


def _dense(model: LinearModel, omega: np.ndarray, mode: str) -> np.ndarray:
    """x per unit input from (I − M) σ = Q by LU at each frequency, refined once with the
    residual in extended precision (LU alone is off by up to 8e-11 of the response at
    4.4e5 rad/s for the PID + notch on the speed output, measured against 50-digit
    arithmetic, where the elimination is off by 1e-15)."""
    s, entries = model._system_at(omega, mode)
    k = {name: i for i, name in enumerate(SIGNALS)}
    m = np.zeros((s.size, 9, 9), dtype=complex)
    for (target, source), gain in entries.items():
        m[:, k[target], k[source]] = gain
    q = np.zeros((s.size, 9, 1), dtype=complex)
    for name, value in model._inputs_at(s, mode).items():
        q[:, k[name], 0] = value
    system = np.eye(9) - m
    first = np.linalg.solve(system, q)
    wide = np.clongdouble
    residual = q.astype(wide) - system.astype(wide) @ first.astype(wide)
    refined = first.astype(wide) + np.linalg.solve(system, residual.astype(complex))
    return refined[:, k["x"], 0].astype(complex)


@pytest.mark.parametrize("mode", ["open", "closed"])
@pytest.mark.parametrize("feedforward", [0.0, 0.5])
@pytest.mark.parametrize("dead_time", [0.0, 2e-4])
@pytest.mark.parametrize("drive", ["angle", "speed", "state_space"])
@pytest.mark.parametrize("loop", ["cascade", "pid_notch"])
def test_elimination_along_the_loop_is_the_dense_solve(loop, drive, dead_time, feedforward,
                                                        mode):
    model_spec, unit = _drive(drive)
    laws, tuned = (CASCADE, TUNED) if loop == "cascade" else (PID_NOTCH, TUNED_PID)
    plant = {"type": "linear", "model": model_spec, "input_unit": "N·m",
             "output_unit": unit, "dead_time": dead_time,
             "velocity_feedforward": feedforward, **laws}
    model = LinearModel(plant, tuned)
    omega = model._grid()
    expected = _dense(model, omega, mode)
    got = model._open(omega) if mode == "open" else model._closed(omega)
    assert np.all(np.abs(got - expected) <= REL * np.abs(expected))


@pytest.mark.parametrize("mode", ["open", "closed"])
@pytest.mark.parametrize("dead_time", [0.0, 2e-4])
@pytest.mark.parametrize("drive", ["angle", "speed", "state_space"])
@pytest.mark.parametrize("loop", ["cascade", "pid_notch"])
def test_one_frequency_in_python_numbers_is_the_array_response(loop, drive, dead_time, mode):
    """Brent's refinements ask for one ω at a time, which the elimination works in Python
    complex numbers (not numpy's 1-element arrays): the same response at every 25th point
    of the grid, to REL of its magnitude (the two round a product or a quotient differently
    in the last bits; measured within 4.5e-15 over the whole grids)."""
    model_spec, unit = _drive(drive)
    laws, tuned = (CASCADE, TUNED) if loop == "cascade" else (PID_NOTCH, TUNED_PID)
    plant = {"type": "linear", "model": model_spec, "input_unit": "N·m",
             "output_unit": unit, "dead_time": dead_time, "velocity_feedforward": 0.5,
             **laws}
    model = LinearModel(plant, tuned)
    response = model._open if mode == "open" else model._closed
    omega = model._grid()[::25]
    whole = response(omega)
    one = np.array([response(float(w)) for w in omega])
    assert one.shape == (omega.size, 1)
    assert np.all(np.abs(one[:, 0] - whole) <= REL * np.abs(whole))
