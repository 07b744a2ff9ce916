"""feedtune.loops.loop.TransferLoop and the polynomial helpers of feedtune.loops.linalg against
numpy.

* Frequency, open-loop and error responses against numpy.polyval on the same polynomials.
* The velocity constant lim s·L(s) against s·L(s) at small s and Bhatia's closed form.
* Stability conditions (of the balanced polynomials) against numpy roots, on seeded random
  polynomials with roots spread over up to five decades (coefficients over 20 orders of
  magnitude, as in Bhatia's loop), with and without an inner loop.
* linalg.balanced_polynomial against the roots it should have (the Hurwitz minors against
  numpy's determinants are in tests/unit/test_linalg.py).
* numeric_transfer against the polynomials and python-control's feedback.
* The tuner's result reports the inner (velocity) loop's stability under "inner_loop".
"""

from __future__ import annotations

import itertools
import math

import casadi as ca
import control
import numpy as np
import pytest

from feedtune.loops import linalg
from feedtune.loops.loop import TransferLoop
from feedtune.plants.hydraulic_rotary import HydraulicRotary, HydraulicRotaryParams
from expression_values import as_number, as_numbers


def _random_roots(rng, degree: int, stable: bool, decades: float) -> np.ndarray:
    """Conjugate pairs and real roots with |root| log-uniform over ``decades`` decades from
    1 rad/s, each at least 5 % of its own magnitude off the imaginary axis (so the sign of
    every test is unambiguous in double precision). ``stable`` False: at least one root in
    the right half plane."""
    while True:
        roots: list[complex] = []
        while len(roots) < degree:
            radius = 10 ** rng.uniform(0, decades)
            pair = degree - len(roots) >= 2 and rng.random() < 0.5
            sign = -1.0 if rng.random() < 0.8 else 1.0
            if pair:
                angle = rng.uniform(0.05, 1.0) * math.pi / 2  # from the imaginary axis
                root = radius * complex(sign * math.sin(angle), math.cos(angle))
                roots += [root, root.conjugate()]
            else:
                roots.append(sign * radius)
        roots = np.array(roots)
        if bool(np.all(roots.real < 0)) == stable:
            return roots


def _poly(roots, lead=1.0) -> np.ndarray:
    return lead * np.real(np.poly(roots))


def _loop_with_characteristic(closed: np.ndarray, inner=None) -> TransferLoop:
    """A type-1 TransferLoop whose closed-loop characteristic polynomial is ``closed``:
    L = c0 / (closed − c0), whose denominator has the factor s."""
    closed = list(map(float, closed))
    return TransferLoop(open_numerator=[closed[-1]], open_denominator=closed[:-1] + [0.0],
                        inner_characteristic=None if inner is None else list(map(float, inner)))


def _bhatia_loop(position_gain=80.0) -> TransferLoop:
    """Bhatia's hand design (Ch. IV F): K'_p = 80 1/s, K'_v = 30 V·s/rad, both lag-leads."""
    params = HydraulicRotaryParams(
        type="hydraulic_rotary", torque_motor_gain=0.254, torque_motor_time_constant=0.01,
        flow_gain=5.44225e-6, displacement=1.38233e-7, hydraulic_natural_frequency=75.0,
        hydraulic_damping=0.5, bulk_modulus=689475729.0, total_volume=4.91612e-6,
        inertia=0.0135582, leakage_coefficient=5.0123e-14,
        velocity_compensator="lag_lead", position_compensator="lag_lead")
    plant = HydraulicRotary(params)
    values = {"position_gain": position_gain, "velocity_gain": 30.0,
              "velocity_compensator.tau1": 10 / 75, "velocity_compensator.tau2": 1 / 75,
              "velocity_compensator.tau12": 10.0, "position_compensator.tau1": 1 / 200,
              "position_compensator.tau2": 1 / 800, "position_compensator.tau12": 1.35 / 200}
    return plant.loop(values, {n: (t.min, t.max) for n, t in plant.tunables().items()})


OMEGAS = np.geomspace(1e-3, 1e5, 41)


# -- responses -------------------------------------------------------------------------------

def _check_responses(loop: TransferLoop, rtol: float):
    num, den = as_numbers(loop.open_numerator), as_numbers(loop.open_denominator)
    closed = np.polyadd(den, num)
    for omega in OMEGAS:
        s = 1j * omega
        expected = {
            "open": np.polyval(num, s) / np.polyval(den, s),
            "closed": np.polyval(num, s) / np.polyval(closed, s),
            "error": np.polyval(den, s) / np.polyval(closed, s),
        }
        got = {"open": loop.open_loop_response(omega), "closed": loop.frequency_response(omega),
               "error": loop.error_response(omega)}
        for name in expected:
            re, im = (as_number(v) for v in got[name])
            # relative to |response|: both are one Horner pass and one complex division
            assert abs(complex(re, im) - expected[name]) <= rtol * abs(expected[name]), (name, omega)


def test_responses_of_random_polynomials_match_polyval():
    rng = np.random.default_rng(1)
    for degree in range(1, 7):
        roots = _random_roots(rng, degree, True, 3)
        den = np.concatenate([_poly(roots, rng.uniform(0.5, 2)), [0.0]])  # type 1: factor s
        num = rng.normal(size=rng.integers(1, degree + 1))
        _check_responses(TransferLoop(list(num), list(den)), rtol=1e-12)


def test_responses_of_bhatias_loop_match_polyval():
    """Coefficients from 1e-16 to 1e4: still 1e-12, the responses are ratios of Horner sums
    with no cancellation between terms of different ω powers at any one frequency ≥ 1e-3."""
    _check_responses(_bhatia_loop(), rtol=1e-12)


def test_error_response_is_exact_where_one_minus_h_cancels():
    """S = den/(den + num) directly: at ω = 1e-6 rad/s, 1 − T loses ~8 digits, S does not."""
    loop = _loop_with_characteristic(_poly([-3.0, -40.0 + 20j, -40.0 - 20j]))
    den, closed = as_numbers(loop.open_denominator), as_numbers(loop.closed_denominator)
    omega = 1e-6
    expected = np.polyval(den, 1j * omega) / np.polyval(closed, 1j * omega)
    re, im = (as_number(v) for v in loop.error_response(omega))
    assert abs(complex(re, im) - expected) <= 1e-13 * abs(expected)


def test_dc_gain_of_a_type_1_loop_is_one():
    assert as_number(_bhatia_loop().dc_gain()) == pytest.approx(1.0, rel=1e-15)


def test_symbolic_responses_equal_numeric():
    """One TransferLoop of MX symbols (the NLP) and one of numbers give the same numbers."""
    k = ca.MX.sym("k")
    den = [1.0, 12.0, 20.0, 0.0]
    sym = TransferLoop([k, 2 * k], den)
    f = ca.Function("responses", [k], [ca.vertcat(*sym.frequency_response(7.0), *sym.error_response(7.0),
                                                  *sym.open_loop_response(7.0), sym.velocity_constant)])
    got = np.array(f(3.5), dtype=float).ravel()
    numeric = TransferLoop([3.5, 7.0], den)
    expected = [as_number(v) for v in (*numeric.frequency_response(7.0), *numeric.error_response(7.0),
                                  *numeric.open_loop_response(7.0), numeric.velocity_constant)]
    np.testing.assert_allclose(got, expected, rtol=1e-14)


# -- velocity constant -----------------------------------------------------------------------

def test_velocity_constant_is_the_limit_of_s_times_l():
    rng = np.random.default_rng(2)
    for _ in range(20):
        den = np.concatenate([_poly(_random_roots(rng, 3, True, 2)), [0.0]])
        num = rng.uniform(0.5, 2.0, size=3)
        loop = TransferLoop(list(num), list(den))
        s = 1e-9j  # s·L(s) = C_v (1 + O(s))
        expected = s * np.polyval(num, s) / np.polyval(den, s)
        assert as_number(loop.velocity_constant) == pytest.approx(expected.real, rel=1e-7)
        assert as_number(loop.velocity_constant) == pytest.approx(num[-1] / den[-2], rel=1e-15)


@pytest.mark.parametrize("position_gain", [80.0, 120.0])
def test_velocity_constant_of_bhatias_loop(position_gain):
    """C_v = K'_p K'_v G(0)/(1 + K'_v G(0)) with G(0) = K_s K_q/D_m (≈ 10 rad/(s·V)): the
    compensators have unit DC gain. 79.73 1/s for K'_p = 80 (Bhatia asks C_v ≥ 80 of the
    optimum; his hand design is 0.3 % short)."""
    g0 = 0.254 * 5.44225e-6 / 1.38233e-7
    expected = position_gain * 30 * g0 / (1 + 30 * g0)
    assert as_number(_bhatia_loop(position_gain).velocity_constant) == pytest.approx(expected, rel=1e-13)


# -- stability conditions --------------------------------------------------------------------

@pytest.mark.parametrize("degree", [2, 3, 4, 5, 6, 8])
@pytest.mark.parametrize("stable", [True, False])
@pytest.mark.parametrize("decades", [1, 5])
def test_stability_conditions_agree_with_numpy_roots(degree, stable, decades):
    """Five decades of roots give coefficients spanning up to 10^(5·8/2) = 1e20 around the
    middle one (Bhatia's loop spans 1e-24 … 1e13 in s-powers): the balanced polynomial keeps
    the Hurwitz minors' signs right where the raw coefficients would not."""
    rng = np.random.default_rng(10_000 * degree + 100 * decades + stable)
    for _ in range(25):
        roots = _random_roots(rng, degree, stable, decades)
        lead = rng.choice([-1.0, 1.0]) * 10 ** rng.uniform(-6, 6)
        loop = _loop_with_characteristic(_poly(roots, lead))
        conditions = as_numbers(loop.stability_conditions())
        assert bool(np.all(conditions > 0)) == stable, (roots, conditions)
        assert np.all(np.isfinite(conditions))
        # the companion matrix carries the same poles (what the validator reads)
        eig = np.linalg.eigvals(np.array(ca.evalf(loop.state_matrix)))
        assert bool(np.all(eig.real < 0)) == stable


@pytest.mark.parametrize("closed_stable, inner_stable", list(itertools.product([True, False], repeat=2)))
def test_inner_loop_must_be_stable_too(closed_stable, inner_stable):
    rng = np.random.default_rng(7 + 2 * closed_stable + inner_stable)
    for _ in range(10):
        closed = _poly(_random_roots(rng, 5, closed_stable, 3))
        inner = _poly(_random_roots(rng, 3, inner_stable, 3))
        loop = _loop_with_characteristic(closed, inner)
        conditions = as_numbers(loop.stability_conditions())
        assert bool(np.all(conditions > 0)) == (closed_stable and inner_stable)
        matrices = loop.stability_matrices()
        assert list(matrices) == ["closed_loop", "inner_loop"]
        inner_poles = np.linalg.eigvals(np.array(ca.evalf(matrices["inner_loop"])))
        np.testing.assert_allclose(np.sort_complex(inner_poles), np.sort_complex(np.roots(inner)),
                                   rtol=1e-8)
        # without an inner loop only the closed loop counts
        alone = as_numbers(_loop_with_characteristic(closed).stability_conditions())
        assert bool(np.all(alone > 0)) == closed_stable


def test_bhatias_loop_is_stable_by_conditions_and_roots():
    loop = _bhatia_loop()
    assert np.all(as_numbers(loop.stability_conditions()) > 0)
    closed = as_numbers(loop.closed_denominator)
    inner = as_numbers(loop.inner_characteristic)
    assert np.all(np.roots(closed).real < 0) and np.all(np.roots(inner).real < 0)
    poly = as_numbers(loop.characteristic_polynomial)
    assert poly[0] == 1.0
    np.testing.assert_allclose(poly, closed / closed[0], rtol=1e-15)


# -- balanced_polynomial ---------------------------------------------------------------------

@pytest.mark.parametrize("seed", range(8))
def test_balanced_polynomial_scales_roots_and_keeps_stability(seed):
    """p(ω0 σ)/(a_n ω0^n), ω0 = |a0/a_n|^(1/n): roots divided by ω0, monic, |constant| 1."""
    rng = np.random.default_rng(seed)
    degree = int(rng.integers(2, 9))
    stable = bool(seed % 2)
    roots = _random_roots(rng, degree, stable, 4)
    p = _poly(roots, rng.choice([-1.0, 1.0]) * 10 ** rng.uniform(-20, 5))
    balanced = as_numbers(linalg.balanced_polynomial([ca.DM(c) for c in p]))
    omega0 = abs(p[-1] / p[0]) ** (1 / degree)
    assert balanced[0] == pytest.approx(1.0, rel=1e-15)
    assert abs(balanced[-1]) == pytest.approx(1.0, rel=1e-12)
    np.testing.assert_allclose(np.sort_complex(np.roots(balanced)), np.sort_complex(roots / omega0),
                               rtol=1e-6, atol=1e-9)  # numpy.roots of a polynomial with
    # roots over four decades: 1e-6 relative on the scaled roots is its own accuracy
    assert bool(np.all(as_numbers(linalg.hurwitz_conditions(list(balanced))) > 0)) == stable


def test_balanced_polynomial_is_symbolic():
    a = ca.MX.sym("a", 4)
    f = ca.Function("balanced", [a], linalg.balanced_polynomial([a[i] for i in range(4)]))
    p = [2.0, 30.0, 400.0, 5000.0]
    got = np.array([float(v) for v in f(p)])
    np.testing.assert_allclose(got, as_numbers(linalg.balanced_polynomial(p)), rtol=1e-15)


# -- numeric_transfer ------------------------------------------------------------------------

def test_numeric_transfer_reference_paths():
    loop = _bhatia_loop()
    num, den = loop.numeric_transfer()
    assert isinstance(num, np.ndarray) and num.dtype == float
    np.testing.assert_array_equal(num, as_numbers(loop.open_numerator))
    np.testing.assert_array_equal(den, as_numbers(loop.closed_denominator))
    err_num, err_den = loop.numeric_transfer(output="error")
    np.testing.assert_array_equal(err_num, as_numbers(loop.open_denominator))
    np.testing.assert_array_equal(err_den, den)
    # position + error = reference: T + S = 1 at every frequency
    for omega in (0.1, 10.0, 1000.0):
        s = 1j * omega
        total = (np.polyval(num, s) + np.polyval(err_num, s)) / np.polyval(den, s)
        assert total == pytest.approx(1.0, rel=1e-12)


def test_numeric_transfer_agrees_with_python_control_feedback():
    """T = feedback(L, 1) built by python-control from the open loop's polynomials."""
    loop = _bhatia_loop()
    open_loop = control.tf(as_numbers(loop.open_numerator), as_numbers(loop.open_denominator))
    reference = control.feedback(open_loop, 1)
    num, den = loop.numeric_transfer()
    for omega in np.geomspace(0.01, 1e4, 25):
        s = 1j * omega
        expected = complex(reference(s))
        assert np.polyval(num, s) / np.polyval(den, s) == pytest.approx(expected, rel=1e-10)


def test_numeric_transfer_load_path():
    """θ per load torque: −(K_ce/D_m²)(1 + V_t s/(4β_e K_ce))·d_t·d_cv·d_cp over the closed
    loop (App. A2 with Merritt's K_ce/D_m²). At DC a type-1 loop rejects a constant load
    through the integrator: the static stiffness is finite and the error is +θ/T_L·T_L."""
    loop = _bhatia_loop()
    num, den = loop.numeric_transfer(input="load")
    np.testing.assert_array_equal(num, as_numbers(loop.load_numerator))
    err, _ = loop.numeric_transfer(output="error", input="load")
    np.testing.assert_array_equal(err, -num)
    kce, dm, vt, be = 5.0123e-14, 1.38233e-7, 4.91612e-6, 689475729.0
    # DC: load numerator at s = 0 is −K_ce/D_m² (every other factor is 1 at s = 0)
    assert num[-1] == pytest.approx(-kce / dm**2, rel=1e-12)
    # the load numerator is −(K_ce/D_m²)(1 + V_t s/(4β_e K_ce)) times the lag polynomials
    lags = np.polymul([0.01, 1.0], np.polymul([10 / 75 * 1 / 75, 10 / 75 + 1 / 75 + 10, 1.0],
                                              [1 / 200 * 1 / 800, 1 / 200 + 1 / 800 + 1.35 / 200, 1.0]))
    expected = -np.polymul([kce / dm**2 * vt / (4 * be * kce), kce / dm**2], lags)
    np.testing.assert_allclose(num, expected, rtol=1e-12)


def test_numeric_transfer_rejects_unknown_inputs():
    loop = TransferLoop([1.0], [1.0, 1.0, 0.0])
    with pytest.raises(ValueError, match="no load input"):
        loop.numeric_transfer(input="load")
    with pytest.raises(ValueError, match="unknown input"):
        _bhatia_loop().numeric_transfer(input="velocity")


# -- the tuner's stability report ------------------------------------------------------------

def _fixed_gains_result(velocity_gain, position_gain, stable_velocity_loop=True):
    """Tune Bhatia's uncompensated drive with both gains fixed (no free tunable: one
    evaluation, no IPOPT)."""
    from feedtune.problem import tune
    from feedtune.schema.spec import parse_spec

    plant = {"type": "hydraulic_rotary", "torque_motor_gain": 0.254,
             "torque_motor_time_constant": 0.01, "flow_gain": 5.44225e-6,
             "displacement": 1.38233e-7, "hydraulic_natural_frequency": 75.0,
             "hydraulic_damping": 0.5, "stable_velocity_loop": stable_velocity_loop}
    return tune(parse_spec({
        "name": "inner-loop", "plant": plant,
        "tunables": {"position_gain": {"value": position_gain},
                     "velocity_gain": {"value": velocity_gain}},
        "objective": [{"metric": "velocity_constant"}], "solver": {"multistart": 1}}))


def test_result_reports_the_inner_loop():
    """K'_v = 0.1: the velocity loop (1 + 0.01s)(s²/75² + s/75 + 1) + 10K'_v is stable
    (Routh: 1 + 10K'_v < 4.08) and so is the position loop at K'_p = 20."""
    result = _fixed_gains_result(0.1, 20.0)
    assert result.success, result.message
    stability = result.stability
    assert stability["stable"] and stability["conditions_hold"]
    inner = stability["inner_loop"]
    assert inner["stable"] and inner["domain"] == "s" and len(inner["poles"]) == 3
    g0 = 0.254 * 5.44225e-6 / 1.38233e-7  # K_s K_q/D_m = 10.00001 rad/(s·V)
    expected = np.roots(np.polyadd(np.polymul([0.01, 1], [1 / 75**2, 1 / 75, 1]), [0.1 * g0]))
    np.testing.assert_allclose(sorted(p[0] for p in inner["poles"]), sorted(expected.real), rtol=1e-9)
    assert len(stability["poles"]) == 4  # the position loop: the velocity loop and 1/s


def test_unstable_inner_loop_is_named():
    """K'_v = 30 without compensation: Bhatia's Fig 21 velocity loop is unstable, and the
    result says which loop failed."""
    result = _fixed_gains_result(30.0, 80.0)
    assert not result.success and result.status == "infeasible"
    assert result.stability["inner_loop"]["stable"] is False
    assert "inner loop stability" in result.message


def test_inner_loop_not_required():
    """stable_velocity_loop false: only the closed loop is checked and reported."""
    result = _fixed_gains_result(0.1, 20.0, stable_velocity_loop=False)
    assert result.success
    assert "inner_loop" not in result.stability
