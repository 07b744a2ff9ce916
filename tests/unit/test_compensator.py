"""Series compensators (feedtune.plants.compensator) against Bhatia 1971 App. C and numpy.

* lag (1 + τ1 s)/(1 + τ2 s) (Table 5) and lag-lead
  (1 + τ1 s)(1 + τ2 s)/(τ1τ2 s² + (τ1 + τ2 + τ12)s + 1) (App. C, Fig 44) as polynomials;
* unit DC gain, so a compensator never changes a loop's velocity constant;
* App. C: the lag-lead's smallest gain (τ1 + τ2)/(τ1 + τ2 + τ12), at ω = 1/√(τ1τ2), with
  zero phase there (lag below, lead above); App. C's worked example τ1 = 1/50, τ2 = 1/250
  with the lag corner at 5 rad/s;
* tunable names ``<loop>_compensator.tau1`` … on the plant.
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from feedtune.plants.compensator import (TAU12_BOUNDS, TAU_BOUNDS, compensator_polynomials,
                                         compensator_tunables)
from feedtune.plants.hydraulic_rotary import HydraulicRotary, HydraulicRotaryParams

PREFIX = "velocity_compensator"

#: Bhatia 1971 Ch. IV data in SI units (as examples/bhatia-1971-hydraulic.json)
BHATIA = {"type": "hydraulic_rotary", "torque_motor_gain": 0.254,
          "torque_motor_time_constant": 0.01, "flow_gain": 5.44225e-6,
          "displacement": 1.38233e-7, "hydraulic_natural_frequency": 75.0,
          "hydraulic_damping": 0.5}


def _floats(p) -> np.ndarray:
    return np.array([float(ca.evalf(ca.MX(c))) if not isinstance(c, (int, float)) else float(c)
                     for c in p])


def _values(tau1, tau2, tau12=None, prefix=PREFIX) -> dict:
    values = {f"{prefix}.tau1": tau1, f"{prefix}.tau2": tau2}
    if tau12 is not None:
        values[f"{prefix}.tau12"] = tau12
    return values


def _response(kind, values, omega) -> np.ndarray:
    num, den = compensator_polynomials(PREFIX, kind, values)
    s = 1j * np.asarray(omega)
    return np.polyval(_floats(num), s) / np.polyval(_floats(den), s)


# -- polynomials -----------------------------------------------------------------------------

def test_none_is_one():
    assert compensator_polynomials(PREFIX, "none", {}) == ([1], [1])
    assert compensator_tunables(PREFIX, "none", "velocity loop") == {}


@pytest.mark.parametrize("tau1, tau2", [(0.1, 0.01), (0.01, 0.1), (2.0, 3e-4)])
def test_lag_polynomials(tau1, tau2):
    num, den = compensator_polynomials(PREFIX, "lag", _values(tau1, tau2))
    np.testing.assert_array_equal(_floats(num), [tau1, 1.0])
    np.testing.assert_array_equal(_floats(den), [tau2, 1.0])
    # a lag (τ2 > τ1) attenuates high frequencies by τ1/τ2, a lead (τ2 < τ1) amplifies
    assert abs(_response("lag", _values(tau1, tau2), 1e6 / min(tau1, tau2))) == pytest.approx(
        tau1 / tau2, rel=1e-6)


@pytest.mark.parametrize("tau1, tau2, tau12", [(10 / 75, 1 / 75, 10.0), (1 / 200, 1 / 800, 1.35 / 200),
                                               (1 / 50, 1 / 250, 441 / 2500)])
def test_lag_lead_polynomials(tau1, tau2, tau12):
    num, den = compensator_polynomials(PREFIX, "lag_lead", _values(tau1, tau2, tau12))
    # (1 + τ1 s)(1 + τ2 s) expanded by numpy, and App. C's denominator
    np.testing.assert_allclose(_floats(num), np.polymul([tau1, 1], [tau2, 1]), rtol=1e-15)
    np.testing.assert_allclose(_floats(den), [tau1 * tau2, tau1 + tau2 + tau12, 1], rtol=1e-15)


@pytest.mark.parametrize("kind", ["none", "lag", "lag_lead"])
def test_unit_dc_gain(kind):
    """Compensators shape the loop without changing C_v: their gain at s = 0 is exactly 1."""
    rng = np.random.default_rng(5)
    for _ in range(20):
        tau1, tau2, tau12 = np.exp(rng.uniform(np.log(1e-4), np.log(100), 3))
        values = _values(tau1, tau2, tau12 if kind == "lag_lead" else None)
        num, den = compensator_polynomials(PREFIX, kind, values)
        assert _floats(num)[-1] == 1.0 and _floats(den)[-1] == 1.0


def test_polynomials_of_symbols_are_the_polynomials_of_numbers():
    """The tuner builds compensators on CasADi symbols; the result on numbers."""
    tau = ca.MX.sym("tau", 3)
    num, den = compensator_polynomials(PREFIX, "lag_lead", _values(tau[0], tau[1], tau[2]))
    f = ca.Function("lag_lead", [tau], [ca.vertcat(*num), ca.vertcat(*den)])
    point = [0.02, 0.004, 0.1764]
    sym_num, sym_den = (np.array(v, dtype=float).ravel() for v in f(point))
    num, den = compensator_polynomials(PREFIX, "lag_lead", _values(*point))
    np.testing.assert_array_equal(sym_num, _floats(num))
    np.testing.assert_array_equal(sym_den, _floats(den))


@pytest.mark.parametrize("seed", range(5))
def test_lag_lead_is_stable_and_minimum_phase(seed):
    """Every τ > 0: numerator roots −1/τ1, −1/τ2; denominator roots real, negative (its
    discriminant (τ1 + τ2 + τ12)² − 4τ1τ2 exceeds (τ1 − τ2)² ≥ 0)."""
    rng = np.random.default_rng(seed)
    tau1, tau2, tau12 = np.exp(rng.uniform(np.log(1e-4), np.log(10), 3))
    num, den = compensator_polynomials(PREFIX, "lag_lead", _values(tau1, tau2, tau12))
    np.testing.assert_allclose(np.sort(np.roots(_floats(num)).real), np.sort([-1 / tau1, -1 / tau2]),
                               rtol=1e-9)
    poles = np.roots(_floats(den))
    assert np.all(poles.real < 0) and np.all(np.abs(poles.imag) == 0)


# -- Bhatia App. C ---------------------------------------------------------------------------

@pytest.mark.parametrize("tau1, tau2, tau12", [
    (1 / 50, 1 / 250, 441 / 2500),        # App. C's example
    (10 / 75, 1 / 75, 10.0),              # Bhatia's velocity-loop design (Ch. IV F)
    (1 / 200, 1 / 800, 1.35 / 200),       # his position-loop design
    (0.3, 0.3, 0.05),                     # τ1 = τ2
])
def test_lag_lead_minimum_gain_at_the_geometric_mean_corner(tau1, tau2, tau12):
    """App. C: |G| is smallest, (τ1 + τ2)/(τ1 + τ2 + τ12), at ω0 = 1/√(τ1τ2), where the phase
    is zero: a lag below ω0, a lead above.

    At s = jω0 both quadratics lose their real parts (1 − τ1τ2ω0² = 0), so G(jω0) is
    exactly the real ratio of the s-coefficients; rounding alone separates the two (1e-12).
    The minimum is located on a dense grid (20 001 points over six decades around ω0,
    0.07 % apart); a quadratic minimum misses its value by O(spacing²) ≪ 1e-6.
    """
    values = _values(tau1, tau2, tau12)
    omega0 = 1 / math.sqrt(tau1 * tau2)
    expected = (tau1 + tau2) / (tau1 + tau2 + tau12)
    at_corner = _response("lag_lead", values, omega0)
    assert at_corner.real == pytest.approx(expected, rel=1e-12)
    assert abs(at_corner.imag) <= 1e-12 * expected
    omega = omega0 * np.geomspace(1e-3, 1e3, 20_001)
    gain = np.abs(_response("lag_lead", values, omega))
    assert gain.min() == pytest.approx(expected, rel=1e-6)
    assert omega[np.argmin(gain)] == pytest.approx(omega0, rel=1e-3)  # two grid steps
    assert np.all(gain >= expected * (1 - 1e-12))
    phase = np.angle(_response("lag_lead", values, omega))
    assert np.all(phase[omega < omega0 * 0.999] < 0) and np.all(phase[omega > omega0 * 1.001] > 0)
    # unit gain at both ends
    assert abs(_response("lag_lead", values, 1e-6 * omega0)) == pytest.approx(1, abs=1e-5)
    assert abs(_response("lag_lead", values, 1e6 * omega0)) == pytest.approx(1, abs=1e-5)


def test_app_c_example_denominator_corners():
    """App. C: τ1 = 1/50 s, τ2 = 1/250 s and a lag corner at 5 rad/s (τ3 = 1/5 s). The
    denominator τ1τ2 s² + (τ1 + τ2 + τ12)s + 1 is (1 + τ3 s)(1 + τ4 s) with τ3τ4 = τ1τ2,
    so τ4 = 1/2500 s, and τ3 + τ4 = τ1 + τ2 + τ12 gives τ12 = 441/2500 s.

    With τ12 = 441/2500 exactly, the factorisation is exact (1/12500 = (1/5)(1/2500),
    501/2500 = 1/5 + 1/2500); the thesis writes it as approximate because it rounds τ12.
    The roots −5 and −2500 are simple and 500 apart, so numpy.roots returns them to a few
    ulp of the larger one: 1e-12 relative. With τ12 rounded to 0.176 s (three digits) the
    corners move to 5.013 and 2495 rad/s: within 0.3 %, the thesis's "approximately".
    """
    tau1, tau2 = 1 / 50, 1 / 250
    tau3 = 1 / 5
    tau4 = tau1 * tau2 / tau3
    assert tau4 == pytest.approx(1 / 2500, rel=1e-15)
    tau12 = tau3 + tau4 - tau1 - tau2
    assert tau12 == pytest.approx(441 / 2500, rel=1e-14)

    _, den = compensator_polynomials(PREFIX, "lag_lead", _values(tau1, tau2, 441 / 2500))
    np.testing.assert_allclose(_floats(den), np.polymul([1 / 5, 1], [1 / 2500, 1]), rtol=1e-14)
    corners = np.sort(-np.roots(_floats(den)).real)
    np.testing.assert_allclose(corners, [5.0, 2500.0], rtol=1e-12)

    _, den = compensator_polynomials(PREFIX, "lag_lead", _values(tau1, tau2, 0.176))
    corners = np.sort(-np.roots(_floats(den)).real)
    np.testing.assert_allclose(corners, [5.0, 2500.0], rtol=3e-3)
    assert not np.allclose(corners, [5.0, 2500.0], rtol=1e-4)  # rounding τ12 does move them

    # the minimum gain of App. C's example: (1/50 + 1/250)/(501/2500) = 60/501 ≈ 0.12 (−18.4 dB)
    values = _values(tau1, tau2, 441 / 2500)
    assert abs(_response("lag_lead", values, math.sqrt(12500))) == pytest.approx(60 / 501, rel=1e-12)


# -- tunables --------------------------------------------------------------------------------

@pytest.mark.parametrize("kind, names", [
    ("none", []),
    ("lag", ["tau1", "tau2"]),
    ("lag_lead", ["tau1", "tau2", "tau12"]),
])
def test_compensator_tunables(kind, names):
    tunables = compensator_tunables(PREFIX, kind, "velocity loop")
    assert list(tunables) == [f"{PREFIX}.{n}" for n in names]
    for name, tunable in tunables.items():
        assert tunable.unit == "s"
        assert "velocity loop" in tunable.description
        bounds = TAU12_BOUNDS if name.endswith("tau12") else TAU_BOUNDS
        assert (tunable.min, tunable.max) == bounds
        assert 0 < tunable.min < tunable.max


def test_app_c_and_bhatia_designs_lie_inside_the_default_bounds():
    """Bhatia's τ12 = 10 s and App. C's corners need no spec-side bounds."""
    for tau in (10 / 75, 1 / 75, 1 / 200, 1 / 800, 1 / 50, 1 / 250):
        assert TAU_BOUNDS[0] <= tau <= TAU_BOUNDS[1]
    for tau12 in (10.0, 1.35 / 200, 441 / 2500):
        assert TAU12_BOUNDS[0] <= tau12 <= TAU12_BOUNDS[1]


@pytest.mark.parametrize("velocity", ["none", "lag", "lag_lead"])
@pytest.mark.parametrize("position", ["none", "lag", "lag_lead"])
def test_plant_tunable_names(velocity, position):
    plant = HydraulicRotary(HydraulicRotaryParams(**BHATIA, velocity_compensator=velocity,
                                                  position_compensator=position))
    expected = ["position_gain", "velocity_gain"]
    for prefix, kind in (("velocity_compensator", velocity), ("position_compensator", position)):
        expected += [f"{prefix}.{n}" for n in {"none": [], "lag": ["tau1", "tau2"],
                                               "lag_lead": ["tau1", "tau2", "tau12"]}[kind]]
    assert list(plant.tunables()) == expected


@pytest.mark.parametrize("kind", ["lag", "lag_lead"])
@pytest.mark.parametrize("where", ["velocity_compensator", "position_compensator"])
def test_compensators_do_not_change_the_velocity_constant(kind, where):
    """C_v = K'_p K'_v G(0)/(1 + K'_v G(0)), G(0) = K_s K_q/D_m = 10 rad/(s·V), with or
    without a compensator in either loop (unit DC gain)."""
    plant = HydraulicRotary(HydraulicRotaryParams(**BHATIA, **{where: kind}))
    box = {n: (t.min, t.max) for n, t in plant.tunables().items()}
    values = {"position_gain": 80.0, "velocity_gain": 30.0,
              **_values(0.05, 0.002, 0.5 if kind == "lag_lead" else None, prefix=where)}
    g0 = 0.254 * 5.44225e-6 / 1.38233e-7
    expected = 80 * 30 * g0 / (1 + 30 * g0)
    assert float(ca.evalf(ca.MX(plant.loop(values, box).velocity_constant))) == pytest.approx(
        expected, rel=1e-12)
