"""Reference tests against Koren 1979 (Y. Koren, ASME J. Eng. Ind., 1979).

Each test cites the equation it reproduces and says why its tolerance is what it is.
Gains are found by the optimiser from the bundled examples, never typed in.
"""

import math

import numpy as np
import pytest

from conftest import load_example, tune_dict
from feedtune.plants.software_servo import SoftwareServo, SoftwareServoParams, koren_step_response

TAU = 0.02  # s, design example
BLU = 5e-6  # m
V_M = 0.04  # m/s


def test_max_pulse_rate_eq1():
    # eq 1: f_m = V_m / BLU = 0.04 / 5e-6 = 8000 pulses/s, stated in the design example
    params = SoftwareServoParams(type="software_servo", technique="sampled_data",
                                 time_constant=TAU, blu=BLU, max_velocity=V_M)
    assert SoftwareServo(params).drive().max_pulse_rate == pytest.approx(8000, rel=1e-12)


def test_reference_pulse_min_radial_error_full_speed(tuned_example):
    # Exact optimum of r·| |H(jω)| − 1 | for K/(τs² + s + K): |H| = 1 at
    # K = (1 + (ωτ)²)/(2τ). ω = 0.04/0.008 = 5 rad/s gives 25.25 1/s. Tolerance: the
    # IPOPT tolerance on a zero-crossing objective, far below 1e-6 relative.
    result = tuned_example("koren-1979-reference-pulse")
    assert result.success
    omega = 0.04 / 0.008
    exact = (1 + (omega * TAU) ** 2) / (2 * TAU)
    assert result.tuned["position_gain"].value == pytest.approx(exact, rel=1e-6)
    # eq 36 (K = 1/(2τ) = 25) is its ωτ → 0 limit; the gap is exactly (ωτ)² = 1 %
    assert result.tuned["position_gain"].value / 25 - 1 == pytest.approx((omega * TAU) ** 2, rel=1e-5)


def test_reference_pulse_eq36_and_eq9_at_small_omega_tau():
    # eqs 11/36: K = 1/(2τ) = 25 1/s and eq 9: ζ = 0.707. At ω = 0.5 rad/s (ωτ = 0.01)
    # the exact optimum is 25·(1 + 1e-4): tolerance 2e-4 covers that known (ωτ)² term.
    spec = load_example("koren-1979-reference-pulse")
    spec["objective"][0]["feed"] = 0.004
    result = tune_dict(spec)
    assert result.tuned["position_gain"].value == pytest.approx(25.0, rel=2e-4)
    assert result.metrics["damping_ratio"].value == pytest.approx(1 / math.sqrt(2), rel=1e-4)


def test_sampled_data_design_example_eq40_eq19_eq42():
    # Design example: T = 1/64 s, eq 40 gives K = 1/(T + 2τ) = 17.98 1/s, eq 19 ζ = 0.704,
    # eq 42: αT = 0.323, ωT = 0.326, M = 0.983. Eq 40 is the ωT → 0 limit of the minimum
    # radial error, so the circle is slowed to ωT = 0.0078 (feed 4 mm/s on 8 mm), where
    # the exact optimum lies 1.1e-4 above eq 40: tolerance 2e-4.
    spec = load_example("koren-1979-sampled-data")
    spec["objective"][0]["feed"] = 0.004
    result = tune_dict(spec)
    assert result.success
    gain = result.tuned["position_gain"].value
    period = result.tuned["sampling_period"].value
    assert gain == pytest.approx(1 / (period + 2 * TAU), rel=2e-4)
    assert gain == pytest.approx(17.98, abs=0.005)  # printed to 4 digits
    # ζ printed to 3 digits: half a unit of the last digit
    assert result.metrics["damping_ratio"].value == pytest.approx(0.704, abs=5e-4)
    _, alpha_t, omega_t, m, zeta = koren_step_response(gain, period, TAU, 1)
    assert zeta == pytest.approx(result.metrics["damping_ratio"].value, rel=1e-9)
    assert alpha_t == pytest.approx(0.323, abs=5e-4)
    assert omega_t == pytest.approx(0.326, abs=5e-4)
    # M = 0.985 at K = 17.98; the paper's 0.983 is M at K rounded to 18 (M(18.0) = 0.9831),
    # see docs/errata.md: tolerance 0.0025 covers that rounding and no more.
    assert m == pytest.approx(0.983, abs=2.5e-3)
    assert koren_step_response(18.0, period, TAU, 1)[3] == pytest.approx(0.983, abs=5e-4)


def test_sampled_data_full_speed_circle_exact_optimum(tuned_example):
    # At Koren's own circle (8 mm at 40 mm/s, ωT = 0.078) the exact optimum moves 1.1 %
    # above eq 40: |H(e^{jωT})| = 1 at K = 18.1734 (root found independently by brentq
    # on a numpy frequency response; tolerance 1e-6 relative).
    from scipy.optimize import brentq

    result = tuned_example("koren-1979-sampled-data")
    period = 1 / 64
    omega = 5.0

    def gain_minus_one(k):
        x = math.exp(-period / TAU)
        phi = np.array([[1, TAU * (1 - x)], [0, x]]) - np.outer([period - TAU * (1 - x), 1 - x], [k, 0])
        gamma = k * np.array([period - TAU * (1 - x), 1 - x])
        h = np.linalg.solve(np.exp(1j * omega * period) * np.eye(2) - phi, gamma)[0]
        return abs(h) - 1

    exact = brentq(gain_minus_one, 10, 30, xtol=1e-12)
    assert result.tuned["position_gain"].value == pytest.approx(exact, rel=1e-6)
    assert result.tuned["position_gain"].value * (period + 2 * TAU) - 1 == pytest.approx(0.0109, abs=5e-4)


@pytest.mark.parametrize("ratio", [0.1, 0.25, 0.5, math.pi / 4, 1.0, 2.0, 3.0])
def test_min_radial_error_locus_eq40(ratio):
    # Fig 6 "min e_r" locus, eq 40: K = 1/(T + 2τ). At ωT = 0.002 the exact optimum differs
    # from eq 40 by O((ωT)²) ≈ 1e-5 relative; the issue asks for 0.1 %.
    spec = load_example("koren-1979-sampled-data")
    period = ratio * TAU
    spec["tunables"]["sampling_period"] = {"value": period}
    spec["constraints"] = []
    spec["objective"][0]["feed"] = 0.002 / period * spec["objective"][0]["radius"]
    result = tune_dict(spec)
    assert result.success
    assert result.tuned["position_gain"].value * (period + 2 * TAU) == pytest.approx(1.0, rel=1e-3)


def test_min_iae_natural_time_gives_k_tau_0567(tuned_example):
    # Text before eq 34: "For T = 0 the minimum IAE criterion results in Kτ = 0.567".
    # Only with time normalised by ω_n (docs/design.md errata). The exact optimum is
    # Kτ = 0.5698 (ζ = 0.662); the issue asks for 1 %.
    result = tuned_example("koren-1979-iae-natural")
    assert result.success
    k_tau = result.tuned["position_gain"].value * TAU
    assert k_tau == pytest.approx(0.567, rel=0.01)
    # eq 34's 0.4 = (2Kτ − 1)/(Kτ)² at that optimum, printed to one digit
    assert (2 * k_tau - 1) / k_tau**2 == pytest.approx(0.4, abs=0.05)


def test_min_iae_plain_time_has_no_interior_optimum_at_t0():
    # docs/design.md errata: in plain time the IAE of K/(s(1+sτ)) falls monotonically with K,
    # so the optimiser must end on the upper gain bound.
    spec = load_example("koren-1979-iae-natural")
    spec["objective"] = [{"metric": "iae", "time": "absolute"}]
    result = tune_dict(spec)
    assert result.tuned["position_gain"].at_bound == "max"


@pytest.mark.parametrize("gain,period", [(17.98, 1 / 64), (20.0, 0.01), (30.0, 0.02), (65.0, 0.02)])
def test_eq16_equals_simulated_step_response(gain, period):
    # Eq 16 (with eqs 17–18) against the loop's own exact discretisation, simulated
    # sample by sample: both are exact, so they agree to rounding (1e-12). Complex poles
    # only (eq 18's arccos); 65 1/s at 50 Hz is Koren's Fig 5 'too high gain'.
    params = SoftwareServoParams(type="software_servo", technique="sampled_data",
                                 time_constant=TAU, blu=BLU, max_velocity=V_M)
    loop = SoftwareServo(params).loop({"position_gain": gain, "sampling_period": period},
                                      {"position_gain": (gain, gain), "sampling_period": (period, period)})
    import casadi as ca

    phi = np.array(ca.evalf(loop.state_matrix))
    gamma = np.array(ca.evalf(loop.input_matrix)).ravel()
    state = np.zeros(phi.shape[0])
    simulated = []
    for _ in range(60):
        simulated.append(state[0])
        state = phi @ state + gamma
    expected = koren_step_response(gain, period, TAU, 60)[0]
    np.testing.assert_allclose(simulated, expected, atol=1e-12)


def test_encoder_constraint_eq26_holds_t_off_its_lower_bound(tuned_example):
    # Eq 26: f_m/f_s ≥ 100 ⇒ T ≥ 100/f_m = 12.5 ms. Minimum IAE alone drives T to its
    # lower bound (5 ms); with the constraint T lands on 12.5 ms. Tolerance: the
    # constraint holds to IPOPT's tolerance.
    result = tuned_example("koren-1979-encoder-limit")
    assert result.success
    assert result.tuned["sampling_period"].value == pytest.approx(100 / 8000, rel=1e-6)
    assert result.tuned["sampling_period"].at_bound is None
    assert result.constraints[0].value == pytest.approx(100, rel=1e-6)
    free = load_example("koren-1979-encoder-limit")
    free["constraints"] = []
    unconstrained = tune_dict(free)
    assert unconstrained.tuned["sampling_period"].at_bound == "min"
    assert unconstrained.objective < result.objective


def test_min_radius_eq39_needs_the_cube_root_coefficient():
    # Design example, reference pulse at K = 1/(2τ): Koren reads r = 7 mm (r/BLU = 1.4e3)
    # off Fig 8. Eq 39 as printed (4·(τf_m)^{4/3}) gives 17.4 mm; with 4^{1/3} it gives
    # 6.894 mm. feedtune's exact minimum radius (root of r·| |H| − 1 | = BLU/2) must match
    # the corrected form; the neglected higher-order terms are ~(ωτ)⁴ ≈ 2e-4 relative.
    spec = load_example("koren-1979-reference-pulse")
    spec["tunables"]["position_gain"] = {"value": 1 / (2 * TAU)}
    result = tune_dict(spec)
    f_m = V_M / BLU
    corrected = 4 ** (1 / 3) * (TAU * f_m) ** (4 / 3) * BLU
    printed = 4 * (TAU * f_m) ** (4 / 3) * BLU
    assert result.metrics["min_radius"].value == pytest.approx(corrected, rel=1e-3)
    assert result.metrics["min_radius"].value == pytest.approx(0.007, abs=0.0005)
    assert abs(result.metrics["min_radius"].value - printed) > 0.01


def test_min_iae_minimum_radius_219_mm(tuned_example):
    # Text after eq 34: BLU = 0.01 mm, V_m = 6 m/min, τ = 20 ms, T·f_m = 100, minimum IAE
    # criterion ⇒ r_min = 219 mm read off Fig 8. The gain comes from the natural-time IAE
    # optimum; eq 32 then gives 220.7 mm. Tolerance 1 %: a value read off a log chart.
    result = tuned_example("koren-1979-min-iae-radius")
    assert result.success
    assert result.metrics["min_radius_koren"].value == pytest.approx(0.219, rel=0.01)
    assert result.metrics["min_radius"].value == pytest.approx(0.219, rel=0.01)


def test_same_spec_same_result(tuned_example):
    # The tuner is deterministic: two runs give bit-identical tuned values and metrics (the
    # first is the session's tuning of the example, made earlier in this process or now)
    spec = load_example("koren-1979-sampled-data")
    first, second = tuned_example("koren-1979-sampled-data"), tune_dict(spec)
    assert first.tuned == second.tuned
    assert first.metrics == second.metrics
    assert first.provenance.spec_sha256 == second.provenance.spec_sha256
