"""The user-defined ``linear`` plant: its spec errors, its loop against python-control, and
the validator's independent model (feedtune/validate/linear.py) against both.

python-control builds each loop from the same numbers with ``tf``, ``feedback`` and
``pade``; tolerances say which scale they are on.
"""

from __future__ import annotations

import copy
import json
from pathlib import Path

import casadi as ca
import control
import numpy as np
import pytest

from feedtune.objectives import METRICS
from feedtune.plants import plant_for
from feedtune.plants.linear_loop import PADE_ORDER, pade
from feedtune.schema.spec import SpecError, parse_spec
from feedtune.validate.linear import LinearModel, pade_block

#: examples/user-defined-drive.json with a notch in its velocity loop (6 tunables)
EXAMPLE = json.loads((Path(__file__).resolve().parents[2] / "examples"
                      / "user-defined-drive.json").read_text())
EXAMPLE["plant"]["notch"] = "velocity_loop"
EXAMPLE["tunables"].update({"notch.frequency": {"min": 800, "max": 3000, "initial": 1732},
                            "notch.width": {"min": 0.05, "max": 1, "initial": 0.5},
                            "notch.depth": {"min": 0.01, "max": 1, "initial": 0.1}})
OMEGAS = np.geomspace(10.0, 2e4, 40)  # rad/s: a decade below the example's bandwidth to
# beyond its resonance and N/T_d


def spec_with(**plant) -> dict:
    spec = copy.deepcopy(EXAMPLE)
    spec["plant"].update(plant)
    return spec


def initial_values(spec: dict) -> dict:
    return {name: t.get("initial", t.get("value")) for name, t in spec["tunables"].items()}


def box(spec: dict) -> dict:
    return {name: (t.get("min", t.get("value")), t.get("max", t.get("value")))
            for name, t in spec["tunables"].items()}


def numeric(pair) -> complex:
    re, im = pair
    return complex(float(ca.evalf(ca.MX(re))), float(ca.evalf(ca.MX(im))))


def loop_of(spec: dict, values: dict | None = None):
    plant = plant_for(parse_spec(spec).plant)
    return plant.loop(values or initial_values(spec), box(spec))


# -- the Padé approximant ----------------------------------------------------------------

def test_pade_is_python_controls():
    """Same coefficients as control.pade (normalised to a monic denominator): 1e-12
    relative, rounding of factorial ratios."""
    num, den = pade(2e-4)
    ref_num, ref_den = control.pade(2e-4, PADE_ORDER)
    np.testing.assert_allclose(np.array(num) / den[0], ref_num, rtol=1e-12)
    np.testing.assert_allclose(np.array(den) / den[0], ref_den, rtol=1e-12)


@pytest.mark.parametrize("x, bound", [(1.0, 4e-8), (2.0, 2e-5)])
def test_pade_phase_error_is_what_the_docs_say(x, bound):
    """linear_loop.PADE_ORDER's comment: 3.8e-8 rad at ωθ = 1, 1.8e-5 rad at ωθ = 2."""
    num, den = pade(1.0)
    value = np.polyval(num, 1j * x) / np.polyval(den, 1j * x)
    assert abs(abs(value) - 1) < 1e-14  # all-pass: the gain is exact
    assert abs(np.angle(value * np.exp(1j * x))) < bound


# -- bad models are refused with the field's pointer -------------------------------------

@pytest.mark.parametrize("model, pointer, words", [
    ({"type": "transfer_function", "numerator": [1, 0, 0], "denominator": [1, 1]},
     "/plant/model/numerator", "improper"),
    ({"type": "transfer_function", "numerator": [1], "denominator": [0, 1, 0]},
     "/plant/model/denominator", "leading"),
    ({"type": "transfer_function", "numerator": [], "denominator": [1, 0]},
     "/plant/model/numerator", "at least 1"),
    ({"type": "transfer_function", "numerator": [0.0], "denominator": [1, 0]},
     "/plant/model/numerator", "zero"),
    ({"type": "zpk", "poles": [0.0], "zeros": [-1.0, -2.0], "gain": 1.0},
     "/plant/model/zeros", "improper"),
    ({"type": "zpk", "poles": [0.0, [-1.0, -5.0]], "gain": 1.0},
     "/plant/model/poles", "im > 0"),
    ({"type": "state_space", "a": [[0, 1], [0, -10]], "b": [[0]], "c": [[1, 0]]},
     "/plant/model/b", "2 rows"),
    ({"type": "state_space", "a": [[0, 1], [0, -10]], "b": [[0], [1]], "c": [[1, 0, 0]]},
     "/plant/model/c", "2 entries"),
    ({"type": "state_space", "a": [[0, 1]], "b": [[0]], "c": [[1]]},
     "/plant/model/a", "1 entry"),
])
def test_bad_model_is_refused_at_its_field(model, pointer, words):
    spec = spec_with(model=model, velocity_controller="none", notch="none",
                     velocity_feedforward=0.0)
    spec["tunables"] = {}
    with pytest.raises(SpecError) as error:
        parse_spec(spec)
    messages = dict(error.value.errors)
    assert pointer in messages, messages
    assert words in messages[pointer]


def test_non_finite_coefficient_is_refused_at_its_pointer():
    text = json.dumps(EXAMPLE).replace('"numerator": [0.002,', '"numerator": [NaN,')
    with pytest.raises(SpecError) as error:
        parse_spec(text)
    assert "/plant/model/numerator/0" in dict(error.value.errors)


@pytest.mark.parametrize("changes, pointer, words", [
    ({"dead_time": -1e-3}, "/plant/dead_time", "greater than or equal to 0"),
    ({"velocity_controller": "none", "notch": "position_loop", "velocity_feedforward": 0.5},
     "/plant/velocity_feedforward", "needs a velocity loop"),
    ({"velocity_controller": "none", "notch": "velocity_loop", "velocity_feedforward": 0.0},
     "/plant/notch", "needs a velocity loop"),
    ({"velocity_controller": "none", "velocity_compensator": "lag", "notch": "none",
      "velocity_feedforward": 0.0}, "/plant/velocity_compensator", "needs a velocity loop"),
    ({"output_unit": "rad/min"}, "/plant/output_unit", "match pattern"),
    # a drive whose position has no integrator in a P position loop: type 0
    ({"model": {"type": "transfer_function", "numerator": [1.0], "denominator": [0.01, 1.0]},
      "velocity_controller": "none", "notch": "none", "velocity_feedforward": 0.0},
     "/plant/position_controller", "type 0"),
    # its velocity s·P is improper: no velocity loop can read it
    ({"model": {"type": "transfer_function", "numerator": [1.0], "denominator": [0.01]}},
     "/plant/velocity_controller", "improper"),
])
def test_bad_loop_is_refused_at_its_field(changes, pointer, words):
    spec = spec_with(**changes)
    spec["tunables"] = {}
    with pytest.raises(SpecError) as error:
        parse_spec(spec)
    messages = dict(error.value.errors)
    assert pointer in messages, messages
    assert words in messages[pointer]


def test_a_pi_position_loop_makes_a_non_integrating_drive_usable():
    spec = spec_with(model={"type": "transfer_function", "numerator": [1.0],
                            "denominator": [0.01, 1.0]},
                     velocity_controller="none", notch="none", velocity_feedforward=0.0,
                     position_controller="pi")
    spec["tunables"] = {}
    assert plant_for(parse_spec(spec).plant).loop_type() == 1


# -- the three model forms are one drive -------------------------------------------------

#: the example's drive: θ_m/T = (J_l s² + c s + k)/(s²(J_m J_l s² + c(J_m + J_l)s + k(J_m + J_l)))
NUM, DEN = EXAMPLE["plant"]["model"]["numerator"], EXAMPLE["plant"]["model"]["denominator"]


def _as_zpk() -> dict:
    zeros = np.roots(NUM)
    poles = np.roots(DEN)

    def pairs(roots):
        out = [float(r.real) for r in roots if abs(r.imag) == 0]
        return out + [[float(r.real), float(r.imag)] for r in roots if r.imag > 0]

    return {"type": "zpk", "zeros": pairs(zeros), "poles": pairs(poles),
            "gain": NUM[0] / DEN[0]}


def _as_state_space() -> dict:
    a, b, c, d = control.ssdata(control.tf2ss(NUM, DEN))
    return {"type": "state_space", "a": a.tolist(), "b": b.tolist(), "c": c.tolist()}


@pytest.mark.parametrize("model", [_as_zpk(), _as_state_space()], ids=["zpk", "state_space"])
def test_zpk_and_state_space_give_the_transfer_functions_loop(model):
    """The closed loop's frequency response agrees to 1e-9 of |T| (≈ 1): the forms differ
    by the rounding of numpy's roots and python-control's realisation."""
    reference = loop_of(EXAMPLE)
    other = loop_of(spec_with(model=model))
    for w in OMEGAS:
        assert abs(numeric(other.frequency_response(w)) - numeric(reference.frequency_response(w))) < 1e-9


def test_state_space_method_is_the_drive():
    """Plant.state_space() (for the sampled engine) has the drive's frequency response
    (relative 1e-12) and the spec's dead time."""
    plant = plant_for(parse_spec(EXAMPLE).plant)
    a, b, c, d, dead_time = plant.state_space()
    assert dead_time == EXAMPLE["plant"]["dead_time"]
    sys_ss = control.ss(a, b, c, d)
    sys_tf = control.tf(NUM, DEN)
    for w in OMEGAS:
        assert abs(sys_ss(1j * w) / sys_tf(1j * w) - 1) < 1e-12


# -- the loop against python-control ---------------------------------------------------------

def control_loop(spec: dict, values: dict, delay_order: int | None):
    """(L, T, S) of the spec's cascade in python-control: the dead time as control.pade of
    ``delay_order`` (None: none), feed-forward as (C_p + k_ff s) on the reference."""
    p = spec["plant"]
    s = control.tf("s")
    drive = control.tf(p["model"]["numerator"], p["model"]["denominator"])
    if delay_order:
        drive = drive * control.tf(*control.pade(p["dead_time"], delay_order))
    kv, ti = values["velocity_controller.kp"], values["velocity_controller.ti"]
    w, z, depth = values["notch.frequency"], values["notch.width"], values["notch.depth"]
    c_v = kv * (1 + 1 / (ti * s)) * (s**2 + 2 * depth * z * w * s + w**2) / (s**2 + 2 * z * w * s + w**2)
    c_p = values["position_controller.kp"]
    velocity = control.minreal(s * drive, verbose=False)
    per_command = control.minreal(control.feedback(c_v * velocity, 1) / s, verbose=False)
    open_loop = c_p * per_command
    closed = (c_p + p["velocity_feedforward"] * s) * per_command / (1 + open_loop)
    return open_loop, closed, 1 - closed


@pytest.mark.parametrize("which, index", [("open_loop_response", 0), ("frequency_response", 1),
                                          ("error_response", 2)])
def test_exact_delay_frequency_response_is_python_controls(which, index):
    """With the dead time exact, L, T and S equal python-control's with a 10th-order Padé
    (its phase error at ωθ ≤ 4 is below 1e-12 rad) to 1e-8 of |·| + 1e-8: the loop's
    values are O(1) at the crossover; far from it |L| spans 1e-3…1e3."""
    loop = loop_of(EXAMPLE)
    reference = control_loop(EXAMPLE, initial_values(EXAMPLE), 10)[index]
    for w in OMEGAS:
        ours, theirs = numeric(getattr(loop, which)(w)), complex(reference(1j * w))
        assert abs(ours - theirs) <= 1e-8 * (1 + abs(theirs)), (w, ours, theirs)


def test_polynomials_hold_the_pade_approximant():
    """The characteristic polynomial's roots are python-control's closed-loop poles with
    control.pade of the same order, to 1e-8 of each pole's magnitude (roots of a 13th-degree
    polynomial whose coefficients span 30 decades)."""
    loop = loop_of(EXAMPLE)
    ours = np.roots([float(ca.evalf(ca.MX(c))) for c in loop.closed_denominator])
    _, closed, _ = control_loop(EXAMPLE, initial_values(EXAMPLE), PADE_ORDER)
    theirs = control.poles(control.minreal(closed, verbose=False))
    assert len(ours) == len(theirs)
    for p in ours:
        assert np.min(np.abs(theirs - p)) < 1e-8 * abs(p)


def test_feedforward_changes_the_reference_path_only():
    """k_ff leaves the characteristic polynomial, L and C_v alone and changes T: the step's
    overshoot and the ramp's steady error (exact: the error numerator's s-coefficient)."""
    values = initial_values(EXAMPLE)
    with_ff = loop_of(EXAMPLE, values)
    without = loop_of(spec_with(velocity_feedforward=0.0), values)
    for a, b in zip(with_ff.closed_denominator, without.closed_denominator):
        assert a == b
    assert with_ff.velocity_constant == without.velocity_constant
    t_ff, t_no = numeric(with_ff.frequency_response(300.0)), numeric(without.frequency_response(300.0))
    assert abs(t_ff - t_no) > 1e-2  # a visible change at the bandwidth
    num_ff, den = with_ff.numeric_transfer("error", "reference")
    num_no, _ = without.numeric_transfer("error", "reference")
    e_ff, e_no = num_ff[-2] / den[-1], num_no[-2] / den[-1]  # ramp steady errors [s]
    assert e_no == pytest.approx(1 / float(ca.evalf(ca.MX(without.velocity_constant))), rel=1e-12)
    assert e_ff < e_no


@pytest.mark.parametrize("dead_time", [0.0, 2e-4])
def test_sensitivity_is_the_feedback_loops_whatever_the_feedforward(dead_time):
    """S = 1/(1 + L) (what M_s reads) is the feedback loop's: with 50 % feed-forward it equals
    python-control's 1/(1 + L) (10th-order Padé for the dead time) to 1e-8 of 1 + |S|, as
    the other responses above, while the error per reference (1 − T) differs from it; and
    M_s is the same with and without feed-forward (the bits of one expression)."""
    spec = spec_with(dead_time=dead_time)
    values = initial_values(spec)
    loop = loop_of(spec, values)
    open_loop = control_loop(spec, values, 10 if dead_time else None)[0]
    sensitivity = 1 / (1 + open_loop)
    for w in OMEGAS:
        ours, theirs = numeric(loop.sensitivity_response(w)), complex(sensitivity(1j * w))
        assert abs(ours - theirs) <= 1e-8 * (1 + abs(theirs)), (w, ours, theirs)
    assert abs(numeric(loop.error_response(300.0)) - numeric(loop.sensitivity_response(300.0))) > 1e-2
    without = loop_of(spec_with(dead_time=dead_time, velocity_feedforward=0.0), values)
    m_s = [float(ca.evalf(ca.MX(METRICS["sensitivity_peak"]().evaluate(lp, None).exact)))
           for lp in (loop, without)]
    assert m_s[0] == m_s[1]


# -- the validator's own model ------------------------------------------------------------

def test_validator_pade_is_python_controls():
    block = pade_block(2e-4)
    sys = control.ss(block.a, block.b, block.c, block.d)
    ref = control.tf(*control.pade(2e-4, PADE_ORDER))
    for w in OMEGAS:
        assert abs(sys(1j * w) - ref(1j * w)) < 1e-12


def test_validator_margins_are_python_controls():
    """GM, PM and crossover of the validator's loop (exact dead time) against
    control.stability_margins of the 10th-order Padé loop: 1e-6 relative (Brent's xtol
    1e-14 in log ω; control refines its crossings on a grid to a few 1e-8)."""
    values = initial_values(EXAMPLE)
    model = LinearModel(EXAMPLE["plant"], values)
    open_loop, _, _ = control_loop(EXAMPLE, values, 10)
    gm, pm, _, wpc, wgc, _ = control.stability_margins(open_loop, returnall=False)
    assert model.phase_margin() == pytest.approx(pm, rel=1e-6)
    assert model.crossover() == pytest.approx(wgc, rel=1e-6)
    assert model.gain_margin() == pytest.approx(gm, rel=1e-6)


def test_validator_poles_are_the_tuners():
    """The validator's closed loop (state space from blocks, signals solved) has the tuner's
    characteristic roots to 1e-8 of each pole's magnitude (see the polynomial test)."""
    values = initial_values(EXAMPLE)
    ours = np.roots([float(ca.evalf(ca.MX(c))) for c in loop_of(EXAMPLE, values).closed_denominator])
    validator = LinearModel(EXAMPLE["plant"], values).poles()
    assert len(ours) == len(validator)
    for p in validator:
        assert np.min(np.abs(ours - p)) < 1e-8 * abs(p)


@pytest.mark.parametrize("plant", [
    {"velocity_feedforward": 0.0, "dead_time": 0.0},
    {},
    {"output_unit": "rad/s", "model": {"type": "state_space", "a": [[-100.0]], "b": [[1.0]],
                                       "c": [[100.0]]},
     "notch": "position_loop", "velocity_controller": "none", "velocity_feedforward": 0.0},
], ids=["no delay, no feed-forward", "example", "velocity output, single loop"])
def test_validator_frequency_response_is_the_tuners(plant):
    """H = x/r and L of the validator (per-frequency signal solve) and of the tuner's loop
    agree to 1e-9 of 1 + |·| (rounding of two different computations)."""
    spec = spec_with(**plant)
    if "notch" in plant and plant["notch"] == "position_loop":
        spec["tunables"].pop("velocity_controller.kp")
        spec["tunables"].pop("velocity_controller.ti")
    values = initial_values(spec)
    loop = loop_of(spec, values)
    open_loop, closed = LinearModel(spec["plant"], values).frequency_response(OMEGAS)
    for w, l_v, h_v in zip(OMEGAS, open_loop, closed):
        assert abs(numeric(loop.frequency_response(w)) - h_v) < 1e-9 * (1 + abs(h_v))
        assert abs(numeric(loop.open_loop_response(w)) - l_v) < 1e-9 * (1 + abs(l_v))


def test_type_two_loop_is_tuned_reported_and_validated():
    """A PI position loop around the example's velocity loop is of type 2: no velocity
    constant is reported (C_v = ∞), the ramp's steady error is exactly 0 on both sides, the
    ramp's settling band is then the step's (1 rad), and the validator agrees with every
    metric (its own tolerances)."""
    from feedtune.problem import tune
    from feedtune.validate.block import validate_result

    spec = spec_with(position_controller="pi", velocity_feedforward=0.0, notch="none")
    spec["tunables"] = {"position_controller.kp": {"value": 100.0},
                        "position_controller.ti": {"value": 0.1},
                        "velocity_controller.kp": {"value": 0.3},
                        "velocity_controller.ti": {"value": 0.01}}
    spec["constraints"] = []
    result = tune(parse_spec(spec))
    assert result.stability["stable"]
    assert "velocity_constant" not in result.metrics
    assert "settling_time(band=0.02,input=ramp)" in result.metrics
    block = validate_result(result)
    assert block["covered"] and block["ok"], [e for e in block["entries"] if not e["ok"]]
    assert any(e["metric"] == "settling_time" and e["options"]["input"] == "ramp"
               for e in block["entries"])


# -- the frequency band (issue 16: a direct loop's k_p is a gain, not a frequency) ---------

PID_NOTCH = json.loads((Path(__file__).resolve().parents[2] / "examples"
                        / "user-defined-pid-notch.json").read_text())


def band_of(spec: dict) -> tuple[float, float]:
    return plant_for(parse_spec(spec).plant).frequency_band(box(spec))


def test_band_of_a_direct_loop_is_its_corners_not_its_gain():
    """examples/user-defined-pid-notch.json: k_p ∈ [1e4, 1e6] N·m/m is no frequency. The
    highest corner over the box is the derivative filter N/T_d = 20/1e-4 = 2e5 rad/s (the
    drive's zero 4.3e4, its mode 1732), the lowest 1/T_d = 10 rad/s: two decades beyond,
    [0.1, 2e7], widened onto the grid's lattice by less than one grid step (6 %).
    Before, the band ran to 100·k_p = 1e8 rad/s."""
    low, high = band_of(PID_NOTCH)
    assert 0.1 * 10 ** (-2 / 40) < low <= 0.1
    assert 2e7 <= high < 2e7 * 10 ** (1 / 40)


def test_band_reaches_a_crossover_beyond_every_corner():
    """A PI position loop on a pure integrator 1000/s (its only corner 1/T_i = 1 rad/s):
    L = 1000 k_p (s + 1)/s², whose crossovers are where the asymptotes meet 1: 1000 k_p
    above the corner (1e9 rad/s at k_p = 1e6), √(1000 k_p) below it (√10 at k_p = 1e-2,
    above the corner, so the corner bounds the low end). The band reaches two decades
    beyond the high one, however k_p's unit scales it."""
    spec = {"name": "integrator", "plant": {
        "type": "linear", "model": {"type": "transfer_function", "numerator": [1000.0],
                                    "denominator": [1.0, 0.0]},
        "input_unit": "m/s", "output_unit": "m", "position_controller": "pi"},
        "tunables": {"position_controller.kp": {"min": 1e-2, "max": 1e6},
                     "position_controller.ti": {"value": 1.0}},
        "objective": [{"metric": "bandwidth", "goal": "maximize"}]}
    low, high = band_of(spec)
    assert high >= 1e11
    assert low <= 1e-2
