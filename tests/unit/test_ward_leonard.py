"""The Ward-Leonard plant (Bhatia 1971 App. B) against an independent state-space model.

The reference model is written from the circuit and torque equations of App. B (generator
field, armature loop, shaft) as ẋ = A x + B u with python-control, and the loops are closed
by python-control's ``interconnect`` from named signals, so no polynomial algebra of the
plant module is reused. Frequency responses agree to rounding (rtol 1e-9: both sides are
double-precision evaluations of the same rational functions, of modest degree ≤ 9).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import control
import numpy as np
import pytest

from feedtune.plants import PLANTS
from feedtune.plants.ward_leonard import WardLeonard, WardLeonardParams, root_moduli
from feedtune.schema.spec import SpecError, parse_spec

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "ward-leonard-feed-drive.json"

#: Palm, System Dynamics 3rd ed., Problem 11.35 (SI units), with some viscous damping kept
PALM = dict(generator_gain=50.0, generator_field_resistance=2.0, generator_field_inductance=0.2,
            armature_resistance=1.0, armature_inductance=0.2, torque_constant=0.5,
            back_emf_constant=0.5, inertia=10.0, viscous_damping=20.0)
#: a faster, lighter drive with distinct constants (k_t ≠ k_b) so no symmetry hides a swap
FAST = dict(generator_gain=120.0, generator_field_resistance=40.0,
            generator_field_inductance=2.0, armature_resistance=0.8, armature_inductance=0.004,
            torque_constant=0.62, back_emf_constant=0.58, inertia=0.012, viscous_damping=0.003)

OMEGAS = np.geomspace(0.01, 1e4, 61)  # rad/s
VALUES = {"position_gain": 20.0, "velocity_gain": 3.0,
          "velocity_compensator.tau1": 0.2, "velocity_compensator.tau2": 0.05,
          "velocity_compensator.tau12": 0.4,
          "position_compensator.tau1": 0.03, "position_compensator.tau2": 0.01,
          "position_compensator.tau12": 0.05}


def plant(data=PALM, velocity="none", position="none", **extra) -> WardLeonard:
    return WardLeonard(WardLeonardParams(type="ward_leonard", **data, velocity_compensator=velocity,
                                         position_compensator=position, **extra))


def box_of(p: WardLeonard) -> dict:
    return {name: (t.min, t.max) for name, t in p.tunables().items()}


def state_space(data: dict) -> control.StateSpace:
    """Generator field, armature loop and shaft of App. B; inputs [e, T_L], outputs [θ̇, θ].

    States [i_fg, i_a, θ̇, θ] (or [i_fg, θ̇, θ] when L_a = 0 and i_a is algebraic).
    """
    lf, rf, kc = (data["generator_field_inductance"], data["generator_field_resistance"],
                  data["generator_gain"])
    la, ra = data["armature_inductance"], data["armature_resistance"]
    kt, kb, j, b = (data["torque_constant"], data["back_emf_constant"], data["inertia"],
                    data.get("viscous_damping", 0.0))
    if la > 0:
        # L_fg di_f = e − R_fg i_f;  L_a di_a = K'_c i_f − R_a i_a − k_b ω;
        # J dω = k_t i_a − B ω − T_L
        a = [[-rf / lf, 0, 0, 0],
             [kc / la, -ra / la, -kb / la, 0],
             [0, kt / j, -b / j, 0],
             [0, 0, 1, 0]]
        bm = [[1 / lf, 0], [0, 0], [0, -1 / j], [0, 0]]
        c = [[0, 0, 1, 0], [0, 0, 0, 1]]
    else:
        # i_a = (K'_c i_f − k_b ω)/R_a
        a = [[-rf / lf, 0, 0],
             [kt * kc / (ra * j), -(b + kt * kb / ra) / j, 0],
             [0, 1, 0]]
        bm = [[1 / lf, 0], [0, -1 / j], [0, 0]]
        c = [[0, 1, 0], [0, 0, 1]]
    return control.ss(a, bm, c, np.zeros((2, 2)), inputs=["e", "TL"], outputs=["w", "th"],
                      name="drive")


def compensator(kind: str, prefix: str, values: dict) -> control.TransferFunction:
    """Bhatia's compensators written directly from their definitions (Table 5, App. C)."""
    if kind == "none":
        return control.tf([1], [1])
    t1, t2 = values[f"{prefix}.tau1"], values[f"{prefix}.tau2"]
    if kind == "lag":
        return control.tf([t1, 1], [t2, 1])
    t12 = values[f"{prefix}.tau12"]
    return control.tf(np.polymul([t1, 1], [t2, 1]), [t1 * t2, t1 + t2 + t12, 1])


def closed_loops(data, velocity, position, values):
    """(position loop [r, T_L] → [θ, θ̇], velocity loop [ω_c, T_L] → θ̇), interconnected."""
    drive = state_space(data)
    cv = control.tf2ss(values["velocity_gain"]
                       * compensator(velocity, "velocity_compensator", values),
                       inputs="ve", outputs="e", name="cv")
    cp = control.tf2ss(values["position_gain"]
                       * compensator(position, "position_compensator", values),
                       inputs="pe", outputs="wc", name="cp")
    vsum = control.summing_junction(inputs=["wc", "-w"], output="ve", name="vsum")
    psum = control.summing_junction(inputs=["r", "-th"], output="pe", name="psum")
    outer = control.interconnect([drive, cv, cp, vsum, psum], inplist=["r", "TL"],
                                 outlist=["th", "w"])
    full = state_space(data)  # the velocity loop does not see θ: drop its integrator state
    velocity_drive = control.ss(full.A[:-1, :-1], full.B[:-1], full.C[:1, :-1], [[0.0, 0.0]],
                                inputs=["e", "TL"], outputs=["w"], name="drive")
    inner = control.interconnect([velocity_drive, cv, vsum], inplist=["wc", "TL"], outlist=["w"])
    return outer, inner


def response(sys, out, inp, omegas):
    """Complex frequency response of one channel of a state-space system."""
    a, b, c, d = (np.asarray(m) for m in (sys.A, sys.B, sys.C, sys.D))
    n = a.shape[0]
    return np.array([(c[out] @ np.linalg.solve(1j * w * np.eye(n) - a, b[:, inp])) + d[out, inp]
                     for w in omegas])


def ratio(num, den, omegas):
    return np.polyval(num, 1j * omegas) / np.polyval(den, 1j * omegas)


def floats(poly):
    return np.array([float(c) for c in poly])


# -- G(s) ------------------------------------------------------------------------------------

@pytest.mark.parametrize("data", [PALM, FAST, {**FAST, "armature_inductance": 0.0}],
                         ids=["palm", "fast", "no_armature_inductance"])
def test_velocity_per_volt_matches_the_circuit_equations(data):
    p = plant(data)
    n_g, d_f, d_m = p.velocity_per_volt()
    assert len(d_f) + len(d_m) - 2 == (3 if data["armature_inductance"] > 0 else 2)
    g = ratio(n_g, np.polymul(d_f, d_m), OMEGAS)
    reference = response(state_space(data), 0, 0, OMEGAS)
    np.testing.assert_allclose(g, reference, rtol=1e-9)


@pytest.mark.parametrize("data", [PALM, FAST], ids=["palm", "fast"])
def test_dc_velocity_gain_formula(data):
    """G(0) = k_t K'_c / (R_fg (R_a B_m + k_t k_b)) [rad/(s·V)]."""
    kt, kb = data["torque_constant"], data["back_emf_constant"]
    expected = kt * data["generator_gain"] / (
        data["generator_field_resistance"] * (data["armature_resistance"] * data["viscous_damping"]
                                              + kt * kb))
    p = plant(data)
    assert p.dc_velocity_gain() == pytest.approx(expected, rel=1e-14)
    full = state_space(data)  # drop the θ state (an integrator) to get the velocity channel
    velocity = control.ss(full.A[:-1, :-1], full.B[:-1, :1], full.C[:1, :-1], [[0.0]])
    assert control.dcgain(velocity) == pytest.approx(expected, rel=1e-9)


def test_palm_numbers():
    """Palm P11.35: τ_f = 0.2/2 = 0.1 s, D(s) = 2s² + 14s + 20.25, G(0) = 12.5/20.25."""
    n_g, d_f, d_m = plant(PALM).velocity_per_volt()
    assert n_g == pytest.approx([12.5]) and d_f == pytest.approx([0.1, 1])
    assert d_m == pytest.approx([2.0, 14.0, 20.25])
    assert plant(PALM).dc_velocity_gain() == pytest.approx(0.6172839506, rel=1e-9)


# -- closed loops ----------------------------------------------------------------------------

CASES = [(PALM, "none", "none"), (PALM, "lag", "lag_lead"), (FAST, "lag_lead", "lag"),
         ({**FAST, "armature_inductance": 0.0}, "lag_lead", "lag_lead")]
CASE_IDS = ["palm-none", "palm-lag-laglead", "fast-laglead-lag", "fast-La0-laglead"]


@pytest.mark.parametrize("data,velocity,position", CASES, ids=CASE_IDS)
def test_closed_loops_match_an_interconnected_state_space_model(data, velocity, position):
    p = plant(data, velocity, position)
    loop = p.loop(VALUES, box_of(p))
    outer, inner = closed_loops(data, velocity, position, VALUES)
    # reference → position, and the complementary error (den L / char)
    num, den = loop.numeric_transfer("position", "reference")
    np.testing.assert_allclose(ratio(num, den, OMEGAS), response(outer, 0, 0, OMEGAS), rtol=1e-8)
    re, im = loop.frequency_response(OMEGAS[20])
    assert complex(float(re), float(im)) == pytest.approx(response(outer, 0, 0, OMEGAS[20:21])[0],
                                                          rel=1e-9)
    # load torque → position, over the same characteristic polynomial
    num_l, den_l = loop.numeric_transfer("position", "load")
    np.testing.assert_allclose(ratio(num_l, den_l, OMEGAS), response(outer, 0, 1, OMEGAS),
                               rtol=1e-8)
    # the same poles (the state-space model has exactly the loop's order here)
    poles = np.sort_complex(np.roots(floats(loop.closed_denominator)))
    np.testing.assert_allclose(poles, np.sort_complex(np.linalg.eigvals(outer.A)), rtol=1e-7)
    # velocity loop on its own
    inner_poles = np.sort_complex(np.roots(floats(loop.inner_characteristic)))
    np.testing.assert_allclose(inner_poles, np.sort_complex(np.linalg.eigvals(inner.A)), rtol=1e-7)


@pytest.mark.parametrize("data,velocity,position", CASES, ids=CASE_IDS)
def test_velocity_constant_and_sensitivity(data, velocity, position):
    """C_v = K'_p K'_v G(0)/(1 + K'_v G(0)) (Bhatia Ch. IV eq 2); sensitivity K'_p K'_v G(0)."""
    p = plant(data, velocity, position)
    loop = p.loop(VALUES, box_of(p))
    kvg = VALUES["velocity_gain"] * p.dc_velocity_gain()
    assert float(loop.velocity_constant) == pytest.approx(VALUES["position_gain"] * kvg / (1 + kvg),
                                                          rel=1e-12)
    assert float(loop.loop_gain_product) == pytest.approx(VALUES["position_gain"] * kvg, rel=1e-12)


@pytest.mark.parametrize("data,velocity,position", CASES, ids=CASE_IDS)
def test_steady_position_error_under_constant_load_torque(data, velocity, position):
    """A proportional position loop holds a constant load T_L with the error
    R_a T_L/(K'_p K'_v k_t K'_c/R_fg).

    At standstill the motor carries I_a = T_L/k_t, which needs E_a = R_a T_L/k_t from the
    generator, i.e. e = E_a R_fg/K'_c across its field, i.e. a velocity error e/K'_v, i.e. a
    position error e/(K'_v K'_p) (compensators have unit DC gain).
    """
    torque = 3.0  # N·m
    expected = (data["armature_resistance"] * torque * data["generator_field_resistance"]
                / (VALUES["position_gain"] * VALUES["velocity_gain"] * data["torque_constant"]
                   * data["generator_gain"]))
    p = plant(data, velocity, position)
    loop = p.loop(VALUES, box_of(p))
    num, den = loop.numeric_transfer("error", "load")
    assert torque * num[-1] / den[-1] == pytest.approx(expected, rel=1e-12)
    outer, _ = closed_loops(data, velocity, position, VALUES)
    assert -torque * control.dcgain(outer)[0, 1] == pytest.approx(expected, rel=1e-9)
    # and the reference is followed exactly: type-1 loop
    assert float(loop.dc_gain()) == pytest.approx(1.0, rel=1e-14)


def test_load_step_settles_to_the_steady_error():
    """Time domain: a 3 N·m load step on Palm's drive, simulated from the state-space model."""
    values = {"position_gain": 5.0, "velocity_gain": 2.0}
    p = plant(PALM)
    assert all(np.roots(floats(p.loop(values, box_of(p)).closed_denominator)).real < 0)
    outer, _ = closed_loops(PALM, "none", "none", values)
    t = np.linspace(0, 40, 4001)
    sim = control.forced_response(outer, t, np.vstack([np.zeros_like(t), 3.0 * np.ones_like(t)]))
    expected = 1.0 * 3.0 * 2.0 / (5.0 * 2.0 * 0.5 * 50.0)
    assert -sim.outputs[0][-1] == pytest.approx(expected, rel=1e-6)


# -- frequency band --------------------------------------------------------------------------

@pytest.mark.parametrize("velocity,position", [("none", "none"), ("lag_lead", "lag_lead")])
def test_frequency_band_covers_every_pole_and_zero_in_the_box(velocity, position):
    p = plant(PALM, velocity, position)
    box = box_of(p)
    low, high = p.frequency_band(box)
    rng = np.random.default_rng(1)
    for _ in range(200):
        values = {n: float(np.exp(rng.uniform(math.log(lo), math.log(hi))))
                  for n, (lo, hi) in box.items()}
        loop = p.loop(values, box)
        for poly in (loop.closed_denominator, loop.open_numerator, loop.inner_characteristic):
            moduli = np.abs(np.roots(floats(poly)))
            moduli = moduli[moduli > 0]
            assert np.all(moduli <= high / 10) and np.all(moduli >= low * 10), (values, moduli)


def test_root_moduli_are_numpys_up_to_rounding():
    """D(s)'s modes set the band's corners in closed form (no numpy for ``feedtune
    validate``): 2 000 quadratics with coefficients over 24 decades (real, double and complex
    pairs) and 200 first-order ones against numpy's companion-matrix roots: modes a decade
    or more apart to 1e-13 of the modulus (a few hundred ulps), closer ones to 1e-7 (rounding
    the coefficients by ε moves a double root by ≈ √ε ≈ 1.5e-8 of its size, whichever way it
    is computed); both far below the two decades the band extends past a corner."""
    rng = np.random.default_rng(7)
    polys = [list(10.0 ** rng.uniform(-12, 12, size=3)) for _ in range(2000)]
    polys += [[a, 2 * math.sqrt(a * c), c] for a, _, c in polys[:100]]  # a double root
    polys += [list(10.0 ** rng.uniform(-12, 12, size=2)) for _ in range(200)]
    for poly in polys:
        expected = sorted(abs(r) for r in np.roots(poly))
        separated = expected[-1] > 10 * expected[0]
        assert sorted(root_moduli(poly)) == pytest.approx(expected, rel=1e-13 if separated
                                                          else 1e-7), poly


def test_root_moduli_refuse_what_double_precision_cannot_hold():
    """a_1/a_0 = 1e310 has no double: an OverflowError, which the spec check reports at
    /plant (numpy raised LinAlgError there, a traceback from `feedtune validate`)."""
    with pytest.raises(OverflowError):
        root_moduli([1e-300, 1e10, 1.0])
    assert root_moduli([2.0, 3.0, 0.0]) == [1.5, 0.0]  # a root at 0, as numpy's roots
    with pytest.raises(SpecError) as err:
        parse_spec(_spec(inertia=1e-150, armature_inductance=1e-150, armature_resistance=1e160))
    (pointer, message), = err.value.errors
    assert pointer == "/plant" and "leave double precision" in message
    assert "a number overflows" in message and "Error" not in message  # not Python's words


# -- spec validation -------------------------------------------------------------------------

def _spec(**plant_changes):
    data = {"type": "ward_leonard", **PALM, **plant_changes}
    data = {k: v for k, v in data.items() if v is not None}
    return {"name": "wl", "plant": data, "objective": [{"metric": "bandwidth", "goal": "maximize"}]}


@pytest.mark.parametrize("field", ["generator_field_resistance", "armature_resistance",
                                   "inertia", "torque_constant", "generator_gain"])
def test_non_positive_parameters_are_errors_naming_the_field(field):
    with pytest.raises(SpecError) as err:
        parse_spec(_spec(**{field: 0.0}))
    assert any(pointer == f"/plant/{field}" and "greater than 0" in message
               for pointer, message in err.value.errors), err.value.errors


def test_negative_inductance_and_damping_are_errors():
    with pytest.raises(SpecError) as err:
        parse_spec(_spec(armature_inductance=-1e-3, viscous_damping=-1.0))
    pointers = {pointer for pointer, _ in err.value.errors}
    assert {"/plant/armature_inductance", "/plant/viscous_damping"} <= pointers


def test_missing_and_unknown_fields_are_errors_naming_them():
    with pytest.raises(SpecError) as err:
        parse_spec(_spec(inertia=None, field_current=2.0))
    pointers = {pointer for pointer, _ in err.value.errors}
    assert {"/plant/inertia", "/plant/field_current"} <= pointers


def test_torque_and_back_emf_constants_in_different_units_are_an_error():
    """51 V/krpm entered as if it were V·s/rad: the message names both fields and the fix."""
    with pytest.raises(SpecError) as err:
        parse_spec(_spec(torque_constant=0.49, back_emf_constant=51.0))
    (pointer, message), = err.value.errors
    assert pointer.startswith("/plant")
    assert "torque_constant" in message and "back_emf_constant" in message and "V/krpm" in message


def test_registered_and_example_parses():
    assert PLANTS["ward_leonard"] is WardLeonard
    spec = parse_spec(EXAMPLE.read_text())
    assert spec.plant.type == "ward_leonard"
    example = json.loads(EXAMPLE.read_text())["plant"]
    assert {k: example[k] for k in PALM} == PALM  # the example is Palm's data, unchanged
