"""The sampled LTI loop's numbers where its closed loop is badly conditioned (the defect
of issue 16 kept as a strict xfail until 2026-11-27: "a Schur condition exactly 0 at
stable grid points, and the symbolic and numeric loops differ").

Causes, each checked here against a value known exactly:
* the characteristic polynomial in z of a loop whose poles cluster at z = 1 (a short T)
  holds p(1) = Π(1 − z_i) ~ 1e-16 in O(1) coefficients, so a stability condition came out
  exactly 0; it is now computed about z = 1 from Φ − I = (e^{AT} − I) + … and the
  command's row entering linearly (``SampledLTILoop.shifted_polynomial``);
* the linear solves (H(1), C_v, every frequency response) went through a QR that loses
  digits as the square of the condition number: C_v of the README's sampled drive was
  9.6e-8 off; they now use partial pivoting.
"""

from __future__ import annotations

import copy
import json
import math
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from feedtune.plants import plant_for
from feedtune.schema.spec import parse_spec
from test_sampled_linear import loop_of

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
SAMPLED_DRIVE = json.loads((EXAMPLES / "user-defined-sampled-drive.json").read_text())
#: the tuned gains of examples/user-defined-sampled-drive.json (tests/data's result)
TUNED = {"position_controller.kp": 138.0077020197471, "velocity_controller.kp": 1.0334019397647496,
         "velocity_controller.ti": 0.01, "sampling_period": 0.001}

#: the contract's sampled backward-Euler case (tests/contract/contract_cases.py): the drive
#: 1/(s(0.01 s + 1)) rad/V, PI velocity loop under P, over its default box
CONTRACT = {"name": "contract", "plant": {
    "type": "linear", "implementation": "sampled", "discretisation": "backward_euler",
    "velocity_controller": "pi", "input_unit": "V", "output_unit": "rad",
    "model": {"type": "transfer_function", "numerator": [1.0], "denominator": [0.01, 1.0, 0.0]}},
    "tunables": {"position_controller.kp": {"min": 0.01, "max": 1000.0},
                 "velocity_controller.kp": {"min": 0.01, "max": 1000.0},
                 "velocity_controller.ti": {"min": 1e-4, "max": 10.0},
                 "sampling_period": {"min": 1e-5, "max": 0.5}},
    "objective": [{"metric": "iae"}]}


def number(x) -> float:
    return float(ca.evalf(ca.MX(x)))


def test_a_stable_loop_with_poles_at_z_near_1_has_positive_conditions():
    """T = 10.2 µs on the 10 ms drive: poles at |z| = 0.99892, 0.99999927, 0.99999983,
    stable by numpy, and every Schur condition positive (one was exactly 0: p(1) ≈ 1e-16
    lost in coefficients of size 3)."""
    loop = loop_of(CONTRACT, {"position_controller.kp": 0.013467987216014356,
                              "velocity_controller.kp": 0.0586812255907619,
                              "velocity_controller.ti": 0.634456301065826,
                              "sampling_period": 1.0220473861607726e-05})
    poles = np.linalg.eigvals(np.array(ca.evalf(loop.state_matrix)))
    assert np.max(np.abs(poles)) < 1 - 1e-7  # stable by 1.7e-7: far from the boundary
    conditions = [number(c) for c in loop.stability_conditions()]
    assert all(c > 0 for c in conditions), conditions
    # and p(1) = Π(1 − z_i) itself, to the eigenvalues' rounding (~1e-16 on 1 − |z| ≥ 1.7e-7)
    p = [number(c) for c in loop.shifted_polynomial]
    assert p[-1] == pytest.approx(np.prod(-(poles - 1)).real, rel=1e-6)


def test_symbolic_and_numeric_polynomials_agree_where_the_gain_is_large():
    """T/T_i = 734 (a backward-Euler PI's feedthrough K(1 + T/T_i) ≈ 1e5): the polynomial
    built on symbols (the NLP's) and on numbers agree to 1e-9 as the plant contract asks
    (they differed by 1.9e-8)."""
    point = {"position_controller.kp": 3.162277660168381,
             "velocity_controller.kp": 146.77992676220683,
             "velocity_controller.ti": 0.0006812920690579617, "sampling_period": 0.5}
    names = list(point)
    z = ca.MX.sym("z", len(names))
    symbolic = loop_of(CONTRACT, {n: ca.exp(z[i]) for i, n in enumerate(names)})
    f = ca.Function("p", [z], [ca.vertcat(*symbolic.characteristic_polynomial),
                               symbolic.velocity_constant])
    sym_poly, sym_cv = f(np.log([point[n] for n in names]))
    numeric = loop_of(CONTRACT, point)
    num_poly = [number(c) for c in numeric.characteristic_polynomial]
    np.testing.assert_allclose(np.array(sym_poly).ravel(), num_poly, rtol=1e-9)
    # a PI velocity loop follows a ramp's rate exactly: the position error is v/K_p, so
    # C_v = K_p (it was 5e-5 off with cond(I − Φ) = 5e5)
    assert number(numeric.velocity_constant) == pytest.approx(point["position_controller.kp"],
                                                              rel=1e-9)
    assert float(sym_cv) == pytest.approx(point["position_controller.kp"], rel=1e-9)


@pytest.mark.parametrize("feedforward", [0.0, 0.5])
def test_the_readme_sampled_drive_follows_a_constant_and_a_ramp_exactly(feedforward):
    """The README's sampled drive at its tuned gains: H(1) = 1 (an integrating loop follows
    a constant), and without feed-forward C_v = K_p (the velocity PI); both were off by
    4e-7 and 9.6e-8 through the QR solve; 1e-12 is rounding of a condition number 5e7."""
    spec = copy.deepcopy(SAMPLED_DRIVE)
    spec["plant"]["velocity_feedforward"] = feedforward
    spec["tunables"] = {name: {"value": value} for name, value in TUNED.items()}
    loop = loop_of(spec, TUNED)
    assert abs(number(loop.dc_gain()) - 1) <= 1e-12
    if feedforward == 0:
        assert number(loop.velocity_constant) == pytest.approx(
            TUNED["position_controller.kp"], rel=1e-12)
    # the characteristic polynomial has numpy's eigenvalues of Φ as its roots
    roots = np.roots([number(c) for c in loop.characteristic_polynomial])
    poles = np.linalg.eigvals(np.array(ca.evalf(loop.state_matrix)))
    for pole in poles:
        assert np.min(np.abs(roots - pole)) <= 1e-9 * max(1.0, abs(pole))
    assert math.isfinite(number(loop.velocity_constant))


def test_the_step_integrals_do_not_depend_on_where_the_tail_starts():
    """The README's sampled drive: the integrals summed sample by sample over 383 or 2357
    samples, then in closed form, are one number. The tail's settled state came from a QR
    solve 4e-7 off, so the tail carried a false constant error, and the ITAE grew with
    the horizon (4.76316e-5 → 4.76375e-5); 1e-9 is the tail's rounding."""
    spec = copy.deepcopy(SAMPLED_DRIVE)
    spec["tunables"] = {name: {"value": value} for name, value in TUNED.items()}
    plant = plant_for(parse_spec(spec).plant)
    box = {name: (value, value) for name, value in TUNED.items()}
    values = []
    for scale in (0.05, 2.0):
        loop = plant.loop(TUNED, box, horizon_scale=scale)
        values.append([number(getattr(loop.step_error_integrals, name))
                       for name in ("iae", "ise", "itae")])
    np.testing.assert_allclose(values[0], values[1], rtol=1e-9)
