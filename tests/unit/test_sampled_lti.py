"""The general sampled-data loop (feedtune.loops.sampled_lti) against Koren's dedicated loop, scipy
and python-control."""

import json
import math
from pathlib import Path

import casadi as ca
import control
import numpy as np
import pytest
from scipy import integrate, linalg, optimize, signal

from feedtune.loops.loop import IntegratorLag, SampledLoop
from feedtune.loops.sampled_controllers import (cascade_controller, discretise_transfer,
                                                error_controller)
from feedtune.loops.sampled_lti import SampledLTILoop
from feedtune.loops.sampled_lti_integrals import _substep, partial_integral
from feedtune.loops.sampled_plants import (ContinuousPlant, DiscretePlant, SampledModelError,
                                           expm_function)
from feedtune.objectives.constants.damping_ratio import DampingRatio
from feedtune.objectives.contour.radial_error import RadialError
from feedtune.problem import tune
from feedtune.schema.spec import parse_spec
from feedtune.tuner import Bound, Problem, Settings, Term, Variable

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
TAU = 0.02  # Koren's drive time constant [s] (examples/koren-1979-sampled-data.json)


def koren_plant(tau=TAU):
    """1/(s(τs + 1)) with the drive's velocity gain folded into K: states [position, velocity]."""
    return ContinuousPlant([[0, 1], [0, -1 / tau]], [0, 1 / tau], [[1, 0]])


def koren_pair(gain, period, delay, box=None, horizon=1.0):
    """(Koren's SampledLoop, the same loop through SampledLTILoop)."""
    box = box or (period, period)
    reference = SampledLoop(IntegratorLag(TAU), gain, period, delay=delay, horizon=horizon,
                            period_min=box[0])
    general = SampledLTILoop(koren_plant(), error_controller([gain], [1], period), period, box,
                             delay=delay, horizon=horizon)
    return reference, general


def evaluate(x):
    return np.array(ca.evalf(ca.MX(x)), dtype=float)


def scalar(x) -> float:
    return float(evaluate(x).ravel()[0])


# -- (a) Koren's software servo ------------------------------------------------------------

POINTS = [(17.0, 1 / 64), (30.0, 0.005), (60.0, 0.01), (10.0, 0.02)]  # (K [1/s], T [s])


@pytest.mark.parametrize("delay", [0, 1])
@pytest.mark.parametrize("gain, period", POINTS)
def test_koren_matrices_and_polynomial_equal_sampled_loop(gain, period, delay):
    reference, general = koren_pair(gain, period, delay)
    for mine, theirs in ((general.state_matrix, reference.state_matrix),
                         (general.input_matrix, reference.input_matrix)):
        a, b = evaluate(mine), evaluate(theirs)
        # entries are transition gains [1], [s] (τ(1 − e^{−T/τ})) and [1/s]: compared against
        # the matrix's own largest entry, 1e-12 is a thousand roundings
        assert a.shape == b.shape
        assert np.max(np.abs(a - b)) <= 1e-12 * np.max(np.abs(b))
    mine = [scalar(c) for c in general.characteristic_polynomial]
    theirs = [scalar(c) for c in reference.characteristic_polynomial]
    # monic polynomial of poles inside the unit disc: coefficients are O(1) (binomials)
    assert np.max(np.abs(np.subtract(mine, theirs))) <= 1e-12


@pytest.mark.parametrize("delay", [0, 1])
@pytest.mark.parametrize("gain, period", POINTS)
def test_koren_step_integrals_equal_sampled_loop(gain, period, delay):
    reference, general = koren_pair(gain, period, delay)
    mine = [float(x) for x in general.step_error_integrals]
    theirs = [float(x) for x in reference.step_error_integrals]
    # sums of positive pieces, at least the first sample's 1 m·T (never near zero): a
    # thousand roundings of the value itself
    for m, t in zip(mine, theirs):
        assert abs(m - t) <= 1e-12 * t


@pytest.mark.parametrize("delay", [0, 1])
def test_koren_symbolic_period_and_gain_equal_sampled_loop(delay):
    """T and K tunable: the same expressions (values and gradients) over the box."""
    k, t = ca.MX.sym("K"), ca.MX.sym("T")
    box = (2e-3, 0.02)
    reference, general = koren_pair(k, t, delay, box=box, horizon=0.5)
    outputs = []
    for loop in (reference, general):
        iae = loop.step_error_integrals.iae
        values = ca.vertcat(*loop.step_error_integrals, *loop.characteristic_polynomial[1:],
                            *loop.error_response(5.0))
        outputs.append(ca.Function("f", [k, t], [values, ca.gradient(iae, ca.vertcat(k, t))]))
    for gain, period in POINTS:
        (v_ref, g_ref), (v_gen, g_gen) = (f(gain, period) for f in outputs)
        # integrals [m·s …] against 1/K, polynomial and S(e^{jωT}) against 1
        assert np.max(np.abs(np.array(v_ref - v_gen))) <= 1e-12
        # dIAE/dK [m·s²] against IAE/K and dIAE/dT [m] against IAE/T, the changes of a
        # relative step in K or T (a gradient is near zero at an optimum: never relative to
        # itself). Both loops differentiate Newton roots after a fixed number of steps, which
        # the cut's e ≈ 0 makes a second-order difference (measured 3e-11 of the scale)
        iae = float(v_ref[0])
        assert abs(float(g_ref[0] - g_gen[0])) <= 1e-9 * iae / gain
        assert abs(float(g_ref[1] - g_gen[1])) <= 1e-9 * iae / period


def test_koren_velocity_constant_and_damping():
    reference, general = koren_pair(17.0, 1 / 64, 0)
    # C_v = K for Koren's loop (type 1, gain K); the ramp error's (I − Φ)⁻² costs 1e-12
    assert scalar(general.velocity_constant) == pytest.approx(17.0, abs=1e-9)
    assert scalar(general.damping_ratio()) == pytest.approx(
        scalar(reference.damping_ratio()), abs=1e-12)


def _tuned_gain(make_loop):
    """Koren's example (examples/koren-1979-sampled-data.json) through the tuner."""
    spec = json.loads((EXAMPLES / "koren-1979-sampled-data.json").read_text())
    circle = RadialError.Options(**{k: v for k, v in spec["objective"][0].items()
                                    if k in ("radius", "feed")})
    problem = Problem(
        [Variable("position_gain", 1.0, 200.0)], {"sampling_period": 0.015625}, make_loop,
        [Term("radial_error", lambda loop: RadialError().evaluate(loop, circle), 1.0)],
        [Bound("damping_ratio", lambda loop: DampingRatio().evaluate(loop, None), 0.5, None)],
        {}, Settings(multistart=8))
    outcome = problem.solve()
    assert outcome.success
    return outcome.values["position_gain"], spec


def test_koren_tuned_gain_equals_dedicated_plant():
    def general(values):
        period = values["sampling_period"]
        return SampledLTILoop(koren_plant(), error_controller([values["position_gain"]], [1],
                                                              period), period,
                              (0.015625, 0.015625))

    gain, spec = _tuned_gain(general)
    dedicated = tune(parse_spec(spec)).tuned["position_gain"].value
    # the tuner's tolerance (tol 1e-9, relative) on the same objective, to rounding
    assert gain == pytest.approx(dedicated, rel=1e-8)
    assert 1 < gain < 200  # an interior optimum: the comparison means something


# -- (b) a 4th-order drive with a resonance, dead time 1.5 T, P + PI cascade -------------

J_M, J_L, STIFFNESS, DAMPING, FRICTION = 1e-3, 2e-3, 200.0, 0.1, 1e-3  # kg·m², N·m/rad, N·m·s/rad
PERIOD = 1e-3  # [s]
K_P, K_V, T_I = 20.0, 0.2, 0.02  # [1/s], [N·m·s/rad], [s]: stable, poles |z| ≤ 0.983


def two_mass():
    """Motor and load coupled by a shaft (resonance √(k(1/J_m + 1/J_l)) ≈ 548 rad/s, ζ ≈ 0.14);
    states [θ_m, ω_m, θ_l, ω_l], input torque [N·m], output the motor's position [rad]."""
    a = np.array([[0, 1, 0, 0],
                  [-STIFFNESS / J_M, -(DAMPING + FRICTION) / J_M, STIFFNESS / J_M, DAMPING / J_M],
                  [0, 0, 0, 1],
                  [STIFFNESS / J_L, DAMPING / J_L, -STIFFNESS / J_L, -DAMPING / J_L]])
    b = np.array([[0], [1 / J_M], [0], [0]])
    c = np.array([[1.0, 0, 0, 0]])
    return a, b, c


def cascade_loop(dead_time, delay=0, method="tustin"):
    a, b, c = two_mass()
    controller = cascade_controller(K_P, [K_V * T_I, K_V], [T_I, 0], PERIOD, method)
    return SampledLTILoop(ContinuousPlant(a, b, c, dead_time=dead_time), controller, PERIOD,
                          (PERIOD, PERIOD), delay=delay, horizon=1.0)


def test_plant_discretisation_equals_scipy_and_control():
    loop = cascade_loop(0.0)
    phi, gamma, gamma1 = (evaluate(m) for m in loop.plant_transition)
    a, b, c = two_mass()
    phi_s, gamma_s, *_ = signal.cont2discrete((a, b, c, np.zeros((1, 1))), PERIOD, "zoh")
    sampled = control.sample_system(control.ss(a, b, c, 0), PERIOD, "zoh")
    for reference_phi, reference_gamma in ((phi_s, gamma_s), (sampled.A, sampled.B)):
        # transition [1 … s, 1/s] against its norm; Γ [rad/(N·m) …] against its own norm
        assert np.max(np.abs(phi - reference_phi)) <= 1e-13 * np.linalg.norm(reference_phi, 1)
        assert np.max(np.abs(gamma - reference_gamma)) <= 1e-13 * np.linalg.norm(reference_gamma, 1)
    assert not np.any(gamma1)


def _fractional_plant(dead_time):
    """(Φ, Γ₀, Γ₁) from scipy alone: x(k+1) = Φx + Γ₀u(k−d) + Γ₁u(k−d−1), θ = dT + θ_f."""
    a, b, c = two_mass()
    whole = math.floor(dead_time / PERIOD + 1e-9)
    fraction = dead_time - whole * PERIOD

    def zoh(h):
        phi, gamma, *_ = signal.cont2discrete((a, b, c, np.zeros((1, 1))), h, "zoh")
        return phi, gamma

    late_phi, late_gamma = zoh(PERIOD - fraction)
    early_phi, early_gamma = zoh(fraction)
    return late_phi @ early_phi, late_gamma, late_phi @ early_gamma, whole


def test_fractional_dead_time_equals_scipy():
    loop = cascade_loop(1.5 * PERIOD)
    phi, gamma0, gamma1, whole = _fractional_plant(1.5 * PERIOD)
    assert loop.held_samples == whole + 1 == 2
    for mine, theirs in zip(loop.plant_transition, (phi, gamma0, gamma1)):
        assert np.max(np.abs(evaluate(mine) - theirs)) <= 1e-13 * np.linalg.norm(theirs, 1)


def _control_closed_loop(dead_time, delay):
    """The cascade closed by python-control: (feedback loop, response r → y). The plant has
    the held commands as extra states, the PI is discretised by control.sample_system
    (Tustin), the loop closed by control.feedback."""
    a, b, c = two_mass()
    phi, gamma0, gamma1, whole = _fractional_plant(dead_time)
    fraction = bool(np.any(gamma1))
    n, lag = 4, whole + delay  # u reaches Γ₀ after lag samples, Γ₁ after lag + 1
    held = lag + fraction  # buffer column n + j − 1 holds u(k − j)
    big_a, big_b = np.zeros((n + held, n + held)), np.zeros((n + held, 1))
    big_a[:n, :n] = phi
    if lag:
        big_a[:n, n + lag - 1] = gamma0[:, 0]
    else:
        big_b[:n] = gamma0
    if fraction:
        big_a[:n, n + lag] = gamma1[:, 0]
    if held:
        big_b[n] = 1
    for i in range(1, held):
        big_a[n + i, n + i - 1] = 1
    outputs = np.zeros((2, n + held))
    outputs[0, :n], outputs[1, :n] = c, c @ a  # position, velocity C A x
    plant = control.ss(big_a, big_b, outputs, np.zeros((2, 1)), PERIOD)
    pi = control.ss(control.sample_system(control.tf([K_V * T_I, K_V], [T_I, 0]), PERIOD,
                                          "tustin"))
    closed = control.feedback(plant, pi * control.ss([], [], [], [[K_P, 1.0]], PERIOD))
    # u = PI·(K_p r − K_p y − v): the reference enters through a copy of the PI
    return closed, (closed * pi * K_P)[0, 0]


@pytest.mark.parametrize("dead_time, delay", [(1.5 * PERIOD, 0), (1.5 * PERIOD, 1),
                                              (2 * PERIOD, 0)])
def test_cascade_poles_and_response_equal_control(dead_time, delay):
    loop = cascade_loop(dead_time, delay)
    mine = np.linalg.eigvals(evaluate(loop.state_matrix))
    closed, response = _control_closed_loop(dead_time, delay)
    theirs = closed.poles()
    assert len(mine) == len(theirs) == 4 + 1 + loop.held_samples
    assert np.max(np.abs(mine)) < 1  # a stable design: the comparison is of a real loop
    # each pole matched to its nearest: poles are O(1) in the z plane, simple ones move by
    # rounding (1e-16) over their separation
    distance = np.abs(mine[:, None] - theirs[None, :])
    assert np.max(np.min(distance, axis=1)) <= 1e-9
    assert np.max(np.min(distance, axis=0)) <= 1e-9
    # the closed-loop frequency response r → y [1] at the samples, up to Nyquist
    for omega in (1.0, 50.0, 548.0, 3000.0, math.pi / PERIOD * 0.999):
        re, im = (scalar(x) for x in loop.frequency_response(omega))
        z = np.exp(1j * omega * PERIOD)
        expected = complex(response(z))
        # |H| is O(1) up to Nyquist; both are exact discrete responses
        assert abs(complex(re, im) - expected) <= 1e-9
    # type 1 through the position loop: C_v = K_p
    assert scalar(loop.velocity_constant) == pytest.approx(K_P, rel=1e-9)


def _hybrid_simulation(dead_time, samples):
    """Step response at the samples by scipy's ODE solver across the held segments, the PI
    as its own Tustin difference equation: nothing shared with the loop under test."""
    a, b, c = two_mass()
    x = np.zeros(4)
    commands = {}  # u(k) by sample
    integral_error, last_error = 0.0, 0.0
    positions = []
    for k in range(samples):
        y, v = (c @ x).item(), (c @ a @ x).item()
        positions.append(y)
        error = K_P * (1.0 - y) - v
        # Tustin PI: u = K_v(e + (T/T_i)·Σ(e(j) + e(j−1))/2)
        integral_error += (error + last_error) / 2 if k else error / 2
        last_error = error
        commands[k] = K_V * (error + PERIOD / T_I * integral_error)
        # held segments of [kT, (k+1)T] seen by the plant through the dead time
        edges = sorted({0.0, PERIOD, *(t for t in (dead_time % PERIOD,) if 0 < t < PERIOD)})
        for start, end in zip(edges[:-1], edges[1:]):
            issued = math.floor(round((k * PERIOD + start - dead_time) / PERIOD, 9))
            u = commands.get(issued, 0.0)
            x = integrate.solve_ivp(lambda t, s: a @ s + b[:, 0] * u, (start, end), x,
                                    method="DOP853", rtol=1e-12, atol=1e-15).y[:, -1]
    return np.array(positions)


def test_cascade_step_response_equals_hybrid_simulation():
    loop = cascade_loop(1.5 * PERIOD)
    phi, gamma = evaluate(loop.state_matrix), evaluate(loop.input_matrix)
    c = evaluate(loop.position_row)
    state, positions = np.zeros((loop.order, 1)), []
    for _ in range(300):
        positions.append((c @ state).item())
        state = phi @ state + gamma
    expected = _hybrid_simulation(1.5 * PERIOD, 300)
    # 1 rad step: DOP853 at rtol 1e-12 over 300 samples, to 1e-9 rad
    assert np.max(np.abs(np.array(positions) - expected)) <= 1e-9
    assert np.max(expected) > 0.5  # the step has been followed: not a trivial comparison


def _dense_integrals(loop, samples):
    """IAE, ISE, ITAE of the 1 rad step error by scipy quadrature of the exact intersample
    error (scipy.linalg.expm), each sample cut at the error's zeros found by brentq on a
    fine grid."""
    a, b, c = two_mass()
    n = 4
    phi, gamma = evaluate(loop.state_matrix), evaluate(loop.input_matrix)
    segments = [(scalar(h), evaluate(k), scalar(r))
                for h, k, r in loop.segments()]
    aug = np.zeros((n + 1, n + 1))
    aug[:n, :n], aug[:n, n:] = a, b
    state, t0 = np.zeros((loop.order, 1)), 0.0
    iae = ise = itae = 0.0
    for _ in range(samples):
        x, start = state[:n, 0], 0.0
        for length, gain_row, gain_ref in segments:
            u = (gain_row @ state).item() + gain_ref

            def error(s, x=x, u=u):
                return 1.0 - (c @ (linalg.expm(aug * s) @ np.append(x, u))[:n]).item()

            grid = np.linspace(0, length, 33)
            values = [error(s) for s in grid]
            cuts = [0.0] + [optimize.brentq(error, lo, hi, xtol=1e-16)
                            for lo, hi, f_lo, f_hi in zip(grid, grid[1:], values, values[1:])
                            if f_lo * f_hi < 0] + [length]
            for lo, hi in zip(cuts, cuts[1:]):
                options = dict(epsabs=1e-15, epsrel=1e-13)
                iae += abs(integrate.quad(error, lo, hi, **options)[0])
                ise += integrate.quad(lambda s: error(s) ** 2, lo, hi, **options)[0]
                itae += abs(integrate.quad(lambda s: (t0 + start + s) * error(s), lo, hi,
                                           **options)[0])
            x = (linalg.expm(aug * length) @ np.append(x, u))[:n]
            start += length
        state = phi @ state + gamma
        t0 += PERIOD
    return iae, ise, itae


def test_cascade_step_integrals_equal_quadrature():
    """The per-sample integration (fold) over the first 60 samples, where the error rings
    and changes sign, against quadrature."""
    loop = cascade_loop(1.5 * PERIOD)
    samples = 60
    mine = [partial_integral(loop, name, samples) for name in ("iae", "ise", "itae")]
    theirs = _dense_integrals(loop, samples)
    # 1 rad step over 0.06 s: IAE ~ 1e-2 rad·s; quadrature to ~1e-13 per piece: 1e-12 of
    # the scale 1 rad·(0.06 s)^k
    for m, t, scale in zip(mine, theirs, (0.06, 0.06, 0.06**2)):
        assert abs(m - t) <= 1e-12 * scale


def test_cascade_step_integrals_tail():
    """A symbolic loop sums horizon/T_min samples then the closed-form tail: ISE is exact
    whatever the horizon (the tail's discrete Lyapunov sum)."""
    period = ca.MX.sym("T")
    a, b, c = two_mass()
    controller = cascade_controller(K_P, [K_V * T_I, K_V], [T_I, 0], period)
    short = SampledLTILoop(ContinuousPlant(a, b, c, dead_time=1.5 * PERIOD), controller, period,
                           (PERIOD, 1.2 * PERIOD), horizon=0.05)  # 50 samples: still ringing
    ise = ca.Function("ise", [period], [short.step_error_integrals.ise])
    long = cascade_loop(1.5 * PERIOD)  # numbers: summed until decayed by 1e-13
    assert short.horizon_samples == 50 < long.horizon_samples
    expected = float(long.step_error_integrals.ise)
    # ISE ~ 3e-2 rad²·s; the settled state (I − Φ)⁻¹Γ, solved symbolically, carries the
    # rounding of a system whose states span rad … N·m (measured 3.8e-11 relative)
    assert float(ise(PERIOD)) == pytest.approx(expected, rel=1e-10, abs=0)


# -- (c) the symbolic exponential ----------------------------------------------------------

def _expm_long_double(m, t):
    """e^{Mt} in 80-bit long double: Taylor to 30 terms on M t/2^s, ‖M t/2^s‖₁ ≤ 1/16,
    squared in the form (I + F)² − I (a reference ~1000× finer than double)."""
    scaled = np.array(m, dtype=np.longdouble) * np.longdouble(t)
    squarings = max(0, math.ceil(math.log2(float(np.linalg.norm(scaled.astype(float), 1))))) + 4
    scaled /= np.longdouble(2) ** squarings
    term, f = np.eye(len(m), dtype=np.longdouble), np.zeros_like(scaled)
    for k in range(1, 30):
        term = term @ scaled / k
        f = f + term
    for _ in range(squarings):
        f = 2 * f + f @ f
    return np.eye(len(m), dtype=np.longdouble) + f


@pytest.mark.parametrize("plant", ["two_mass", "koren"])
def test_expm_equals_scipy_over_the_period_box(plant):
    """e^{Mt} of the ZOH's augmented M = [[A, B], [0, 0]] for t in [1e-4, 1e-1] s, one
    Function built for t_max = 0.1 s (as for a tunable T in that box), and its derivative."""
    if plant == "two_mass":
        a, b, _ = two_mass()
    else:
        a, b = koren_plant().a, koren_plant().b
    n = a.shape[0]
    m = np.zeros((n + 1, n + 1))
    m[:n, :n], m[:n, n:] = a, b
    expm = expm_function(m, 0.1)
    t = ca.SX.sym("t")
    d_expm = ca.Function("d", [t], [ca.jacobian(ca.vec(expm(t)), t)])
    long_double = np.finfo(np.longdouble).eps < 1e-18  # x86: 80-bit
    for value in np.geomspace(1e-4, 1e-1, 31):
        mine, theirs = np.array(expm(value)), linalg.expm(m * value)
        # entries mix units (1, s, rad/(N·m·s) …): each column against its own largest
        # entry, one unit per column. scipy's own error reaches 3e-11 of a column on the
        # two-mass drive at t = 0.1 s (against the 80-bit reference), ours 4e-14
        scale = np.max(np.abs(theirs), axis=0)
        assert np.max(np.abs(mine - theirs) / scale) <= 1e-10
        if long_double:
            exact = _expm_long_double(m, value)
            assert np.max((np.abs(mine - exact) / scale).astype(float)) <= 1e-13
        # d/dt e^{Mt} = M e^{Mt}: the derivatives the tuner takes with respect to T, against
        # |M|·|e^{Mt}|, the scale at which the product M e^{Mt} itself rounds
        d_mine = np.array(d_expm(value)).reshape(n + 1, n + 1, order="F")
        d_scale = np.max(np.abs(m) @ np.abs(theirs), axis=0)
        d_scale[d_scale == 0] = 1.0  # an integrating plant: M e^{Mt} has a zero column
        assert np.max(np.abs(d_mine - m @ theirs) / d_scale) <= 1e-12


# -- controllers, tunable T with a dead time, discrete plants, bad input ----------------------

@pytest.mark.parametrize("method, scipy_method", [("tustin", "bilinear"),
                                                  ("backward_euler", "backward_diff")])
def test_controller_discretisation_equals_scipy(method, scipy_method):
    """A PI and a lead (K(τ₁s + 1)/(τ₂s + 1)) in z against scipy.signal.cont2discrete."""
    for numerator, denominator in (([K_V * T_I, K_V], [T_I, 0]), ([2.0 * 0.01, 2.0], [0.001, 1])):
        num_z, den_z = discretise_transfer(numerator, denominator, PERIOD, method)
        num_z = np.array([scalar(c) for c in num_z]) / scalar(den_z[0])
        den_z = np.array([scalar(c) for c in den_z]) / scalar(den_z[0])
        expected_num, expected_den, _ = signal.cont2discrete((numerator, denominator), PERIOD,
                                                             scipy_method)
        expected_num = np.ravel(expected_num) / expected_den[0]
        expected_den = np.asarray(expected_den) / expected_den[0]
        # monic denominators: coefficients O(1); numerators in N·m·s/rad (gain K_V)
        assert np.max(np.abs(den_z - expected_den)) <= 1e-12
        assert np.max(np.abs(num_z - expected_num[-len(num_z):])) <= 1e-12 * np.max(
            np.abs(expected_num))


def test_tunable_period_with_fractional_dead_time_equals_fixed_periods():
    """T a symbol over [0.8, 1.2] ms with θ = 1.5 ms fixed: one whole sample plus
    θ_f = θ − T; the loop at each T equals the loop built on that number."""
    period = ca.MX.sym("T")
    a, b, c = two_mass()
    controller = cascade_controller(K_P, [K_V * T_I, K_V], [T_I, 0], period)
    loop = SampledLTILoop(ContinuousPlant(a, b, c, dead_time=1.5e-3), controller, period,
                          (0.8e-3, 1.2e-3))
    outputs = ca.Function("f", [period], [loop.state_matrix, loop.input_matrix,
                                          ca.vertcat(*loop.frequency_response(300.0))])
    for value in (0.8e-3, 1e-3, 1.2e-3):
        fixed_controller = cascade_controller(K_P, [K_V * T_I, K_V], [T_I, 0], value)
        fixed = SampledLTILoop(ContinuousPlant(a, b, c, dead_time=1.5e-3), fixed_controller,
                               value, (value, value))
        phi, gamma, response = outputs(value)
        # transition entries against the matrix's largest; H(e^{jωT}) [1] against 1
        assert np.max(np.abs(np.array(phi) - evaluate(fixed.state_matrix))) <= 1e-12 * np.max(
            np.abs(evaluate(fixed.state_matrix)))
        assert np.max(np.abs(np.array(gamma) - evaluate(fixed.input_matrix))) <= 1e-12 * np.max(
            np.abs(evaluate(fixed.input_matrix)))
        expected = [scalar(x) for x in fixed.frequency_response(300.0)]
        # H [1] against 1: the resolvent (e^{jωT}I − Φ)⁻¹ amplifies Φ's rounding (two
        # exponentials built for different boxes) by its condition number, states of mixed
        # units (measured 1.0e-12)
        assert np.max(np.abs(np.ravel(np.array(response)) - expected)) <= 1e-10


def test_dead_time_whose_whole_samples_change_over_the_box_is_refused():
    a, b, c = two_mass()
    period = ca.MX.sym("T")
    controller = cascade_controller(K_P, [K_V * T_I, K_V], [T_I, 0], period)
    loop = SampledLTILoop(ContinuousPlant(a, b, c, dead_time=1.5e-3), controller, period,
                          (0.5e-3, 2e-3))  # θ spans 0.75 … 3 samples
    with pytest.raises(SampledModelError, match="/plant/dead_time"):
        loop.state_matrix
    # in samples, θ = 1.5·T splits for any T: the whole count is fixed
    scaled = SampledLTILoop(ContinuousPlant(a, b, c, dead_time_samples=1.5), controller, period,
                            (0.5e-3, 2e-3))
    assert scaled.held_samples == 2


def test_discrete_plant_equals_the_continuous_one_at_its_period():
    a, b, c = two_mass()
    phi, gamma, *_ = signal.cont2discrete((a, b, c, np.zeros((1, 1))), PERIOD, "zoh")
    controller = cascade_controller(K_P, [K_V * T_I, K_V], [T_I, 0], PERIOD)
    with pytest.raises(SampledModelError, match="velocity"):
        SampledLTILoop(DiscretePlant(phi, gamma, c, period=PERIOD, dead_time_samples=2),
                       controller, PERIOD, (PERIOD, PERIOD)).state_matrix
    pi = error_controller([K_V * T_I * 1e3, K_V * 1e3], [T_I, 0], PERIOD)
    discrete = SampledLTILoop(DiscretePlant(phi, gamma, c, period=PERIOD, dead_time_samples=2),
                              pi, PERIOD, (PERIOD, PERIOD))
    continuous = SampledLTILoop(ContinuousPlant(a, b, c, dead_time=2 * PERIOD), pi, PERIOD,
                                (PERIOD, PERIOD))
    # Φ_cl entries against the largest (transition gains of mixed units)
    expected = evaluate(continuous.state_matrix)
    assert np.max(np.abs(evaluate(discrete.state_matrix) - expected)) <= 1e-12 * np.max(
        np.abs(expected))
    assert not discrete.has_exact_step_error
    with pytest.raises(SampledModelError, match="/tunables/sampling_period"):
        SampledLTILoop(DiscretePlant(phi, gamma, c, period=PERIOD), pi, 2 * PERIOD,
                       (2 * PERIOD, 2 * PERIOD))


@pytest.mark.parametrize("build, pointer", [
    (lambda: ContinuousPlant([[0, 1], [0, -50]], [0, 50], [[1, 0]], d=1.0), "/plant/d"),
    (lambda: ContinuousPlant([[0, 1], [0, -50]], [0, 50], [[1, 0]], dead_time=-1e-3),
     "/plant/dead_time"),
    (lambda: ContinuousPlant([[0, 1], [0, math.nan]], [0, 50], [[1, 0]]), "/plant/a"),
    (lambda: ContinuousPlant([[0, 1], [0, -50]], [0, 50, 1], [[1, 0]]), "/plant/b"),
    (lambda: ContinuousPlant([[0, 1], [0, -50]], [0, 50], [[1, 0]], dead_time=1e-3,
                             dead_time_samples=1.0), "/plant/dead_time"),
    (lambda: DiscretePlant([[1]], [1], [[1]], period=1e-3, dead_time_samples=1.5),
     "/plant/dead_time_samples"),
    (lambda: discretise_transfer([1, 0, 0], [1, 1], 1e-3), "/controller"),
    (lambda: discretise_transfer([1], [1, 1], 1e-3, "forward"), "/controller/method"),
    (lambda: SampledLTILoop(koren_plant(), error_controller([10.0], [1], 1e-3), 1e-3,
                            (1e-3, 1e-3), delay=-1), "/controller/delay"),
    (lambda: ContinuousPlant([[0, 1], [0, -50]], [1, 50], [[1, 0]]).velocity_row, "/plant"),
])
def test_bad_models_name_the_field(build, pointer):
    with pytest.raises(SampledModelError, match=pointer):
        build()


@pytest.mark.parametrize("roots", [(0.3, 0.6), (0.45, 0.4501), (0.2, 0.95)])
def test_substep_cuts_two_zeros_and_the_extremum(roots):
    """∫|e|, ∫t|e| and ∫e² of e = (x − a)(x − b)(x + 2) on one sub-step [0, 1] (h = 2 ms,
    starting at t = 5 ms): two zeros and an extremum between them, the case where a loop's
    error overshoots and returns within one sample (rare: no loop of the tests does it)."""
    a, b = roots
    e = np.polymul(np.polymul([1, -a], [1, -b]), [1, 2])  # highest power first
    coefficients = [ca.DM(c) for c in e[::-1]]  # ascending, as the loop gives them
    h, start = 2e-3, 5e-3
    cuts = [0.0, a, b, 1.0]

    def integral(poly, lo, hi):
        antiderivative = np.polyint(poly)
        return np.polyval(antiderivative, hi) - np.polyval(antiderivative, lo)

    time_weighted = np.polyadd(np.polymul([h, start], e), [0])  # (t_start + h x)·e
    expected = {
        "iae": h * sum(abs(integral(e, lo, hi)) for lo, hi in zip(cuts, cuts[1:])),
        "itae": h * sum(abs(integral(time_weighted, lo, hi)) for lo, hi in zip(cuts, cuts[1:])),
        "ise": h * integral(np.polymul(e, e), 0, 1),
    }
    for name, value in expected.items():
        mine = float(_substep(coefficients, 1.0, h, start, name))
        # e is O(1) on [0, 1]: 1e-14 of h (m·s), of h·(t + h) (m·s²)
        scale = h * (start + h) if name == "itae" else h
        assert abs(mine - value) <= 1e-14 * scale


@pytest.mark.parametrize("velocity_gain, stable", [(0.2, True), (0.6, True), (1.0, False),
                                                   (1.5, False)])
def test_schur_conditions_agree_with_eigenvalues(velocity_gain, stable):
    """The tuner's stability rows (Hurwitz conditions of the bilinear map) hold exactly when
    every pole is inside the unit circle: K_V = 1 N·m·s/rad destabilises the loop."""
    a, b, c = two_mass()
    controller = cascade_controller(K_P, [velocity_gain * T_I, velocity_gain], [T_I, 0], PERIOD)
    loop = SampledLTILoop(ContinuousPlant(a, b, c, dead_time=1.5 * PERIOD), controller, PERIOD,
                          (PERIOD, PERIOD))
    radius = np.max(np.abs(np.linalg.eigvals(evaluate(loop.state_matrix))))
    conditions = [scalar(x) for x in loop.stability_conditions()]
    assert abs(radius - 1) > 1e-3  # clear of the boundary: the verdict is not rounding
    assert (radius < 1) == stable
    assert all(x > 0 for x in conditions) == stable


#: what metrics, the tuner and feedtune.schema.spec read from a sampled loop
LOOP_INTERFACE = ("discrete", "period", "period_min", "horizon", "order", "drive",
                  "interpolator", "has_exact_step_error", "horizon_samples",
                  "symbolic_horizon_samples", "unrolled_steps")


def test_loop_interface_equals_sampled_loop():
    """The attributes the rest of feedtune reads give the same answers on Koren's loop."""
    k, t = ca.MX.sym("K"), ca.MX.sym("T")
    for gain, period in ((17.0, 1 / 64), (k, t)):
        reference, general = koren_pair(gain, period, 1, box=(2e-3, 0.02), horizon=0.5)
        for name in LOOP_INTERFACE:
            assert getattr(general, name) is getattr(reference, name) or (
                getattr(general, name) == getattr(reference, name)), name
        for method in ("stability_conditions", "settling_conditions", "stability_matrices",
                       "characteristic_polynomial", "velocity_constant", "state_matrix",
                       "input_matrix", "position_row", "frequency_response",
                       "error_response", "step_error_integrals"):
            assert hasattr(general, method), method
    assert general.symbolic_horizon_samples == 250  # 0.5 s / 2 ms


def test_velocity_feedforward_follows_a_ramp_without_steady_error():
    a, b, c = two_mass()
    loops = {}
    for feedforward in (False, True):
        controller = cascade_controller(K_P, [K_V * T_I, K_V], [T_I, 0], PERIOD,
                                        feedforward=feedforward)
        loops[feedforward] = SampledLTILoop(ContinuousPlant(a, b, c, dead_time=1.5 * PERIOD),
                                            controller, PERIOD, (PERIOD, PERIOD))

    def ramp_error(loop):  # e_ss [rad] of r(k) = kT·1 rad/s: T·C(I − Φ)⁻²Γ
        phi, gamma = evaluate(loop.state_matrix), evaluate(loop.input_matrix)
        eye = np.eye(loop.order)
        settled = np.linalg.solve(eye - phi, np.linalg.solve(eye - phi, gamma))
        return PERIOD * (evaluate(loop.position_row) @ settled).item()

    assert ramp_error(loops[False]) == pytest.approx(1 / K_P, rel=1e-9)  # C_v = K_p
    # against the 1/K_p = 50 mrad the P loop leaves: the feed-forward cancels it
    assert abs(ramp_error(loops[True])) <= 1e-9 / K_P
    # one more pole, at z = 0 (the state r(k−1)); the others unchanged
    with_ff = np.sort_complex(np.linalg.eigvals(evaluate(loops[True].state_matrix)))
    without = np.sort_complex(np.linalg.eigvals(evaluate(loops[False].state_matrix)))
    assert len(with_ff) == len(without) + 1
    nonzero = with_ff[np.abs(with_ff) > 1e-6]
    assert np.max(np.min(np.abs(nonzero[:, None] - without[None, :]), axis=1)) <= 1e-9


@pytest.mark.parametrize("name", ["iae", "ise", "itae"])
def test_a_loop_of_numbers_sizes_its_substeps_for_its_own_period(name):
    """Koren's loop at T = 5 ms in a period box up to 0.5 s: the loop of numbers cuts each
    sample into sub-steps sized for its own period (rounded up to a power of two: 7.8 ms),
    not for the box's 0.5 s (the NLP's structure, which must serve every T of the box), and
    sums the same integral: the error is its Taylor polynomial to rounding on either cut."""
    from feedtune.loops import sampled_lti_integrals as integrals

    gain, period = 30.0, 0.005
    _, loop = koren_pair(gain, period, 0, box=(1e-3, 0.5))
    samples = loop.horizon_samples
    key = integrals._key(loop, samples, numeric=True)
    assert key[6] == 2.0**-7  # the t_max its sub-steps serve [s]
    mine = float(integrals.step_integral(loop, name, samples, numeric=True))
    step, tail = integrals._functions(integrals._key(loop, samples), name)  # sized for 0.5 s
    args = integrals._arguments(loop, True)
    final = step.fold(samples)(ca.DM.zeros(loop.order + 2), *args)
    rest = float(tail(final[:loop.order], final[loop.order + 1], *args))
    box_sized = float(final[loop.order]) + (rest if name == "ise" else abs(rest))
    # a unit step's IAE 0.042 m·s: 1e-12 relative is ~1e4 roundings of the 261 samples'
    # sums (measured ≤ 6.6e-15), far below what a wrong cut would change
    assert mine == pytest.approx(box_sized, rel=1e-12)


@pytest.mark.parametrize("dead_time, delay", [(0.0, 0), (1.5e-3, 1)])
def test_a_loop_of_numbers_assembles_its_matrices_on_numbers(dead_time, delay):
    """A loop of numbers holds Φ, Γ, the open loop's matrices and its polynomial as DM
    (numbers computed once, not MX graphs of constants each reader evaluates again), equal
    to the same loop built on symbols and evaluated at those numbers: the same operations,
    so to the last bit, the signs of zeros aside (CasADi's select adds 0 to what it picks)."""
    a, b, c = two_mass()
    plant = ContinuousPlant(a, b, c, dead_time=dead_time)
    gains = ca.MX.sym("gains", 3)  # K_p, and K_v, T_i of the velocity PI

    def loop(k_p, k_v, t_i):
        controller = cascade_controller(k_p, [k_v * t_i, k_v], [t_i, 0], PERIOD)
        return SampledLTILoop(plant, controller, PERIOD, (PERIOD, PERIOD), delay=delay,
                              horizon=1.0)

    numbers, symbols = loop(K_P, K_V, T_I), loop(gains[0], gains[1], gains[2])
    read = [lambda lp: lp.state_matrix, lambda lp: lp.input_matrix,
            lambda lp: lp.open_loop_matrices[0], lambda lp: lp.open_loop_matrices[1],
            lambda lp: ca.vertcat(*lp.characteristic_polynomial)]
    for part in read:
        value = part(numbers)
        assert isinstance(value, ca.DM)
        graph = ca.Function("part", [gains], [part(symbols)])([K_P, K_V, T_I])
        np.testing.assert_array_equal(np.array(value, dtype=float), np.array(graph, dtype=float))
