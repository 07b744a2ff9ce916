"""Frequency and step-shape metrics of the sampled-data software servo (issue 16, item 3),
checked against python-control and against the validator's own model.

python-control builds each loop itself: the drive K/(s(1 + sτ)) (or K/s) discretised with
``control.sample_system(..., 'zoh')``, times z^{−d} for the computation delay. Its
``control.margin`` gives the margins and crossovers, its transfer-function evaluation at
z = e^{jωT} the closed loop for M_peak and the bandwidth, and its step response at the
samples bounds the overshoot and settling time; between samples the position comes from
the drive discretised by python-control over the part of the period elapsed.

Tolerances, each on the quantity's physical scale:

* margins and crossovers: python-control solves polynomials in z, feedtune brackets and
  takes Newton steps; both are exact to rounding (measured ≤ 3e-14 relative), so a ratio
  or a frequency to 1e-9 relative, an angle to 1e-9 × 180°, a frequency located at the
  Nyquist frequency to 1e-9 × π/T (the bisection there holds it to 2⁻³² of a grid step);
* M_peak to 1e-9 of the unit DC gain (both polished maxima of one function: an error δ in
  ω moves the value by O(δ²));
* overshoot to 1e-9 of the 1 m step and settling time to 1e-9 × T: exact on both sides
  (closed form against python-control's ZOH matrices polished by Brent).
"""

from __future__ import annotations

import json
import math

import casadi as ca
import control
import numpy as np
import pytest
from scipy.optimize import brentq, minimize_scalar

from discrete_checks import control_peak_and_bandwidth
from feedtune.objectives import METRICS
from feedtune.plants.software_servo import SoftwareServo, SoftwareServoParams
from feedtune.tuner.terms import exact_value
from feedtune.validate import sampled_frequency
from feedtune.validate.software_servo import ServoModel

TAU = 0.02  # Koren's design example [s]
#: (K [1/s], T [s], computation delay, τ [s] or None): Koren's design (K = 18, f_s = 64 Hz),
#: faster sampling with one sample of delay, a stiff loop, Sato's ideal drive with delay
CASES = [(18.0, 1 / 64, 0, TAU), (40.0, 0.005, 1, TAU), (60.0, 1 / 64, 0, TAU),
         (25.0, 0.002, 2, TAU), (30.0, 0.01, 1, None), (10.0, 0.004, 1, None)]
FREQUENCY = ["m_peak", "bandwidth", "crossover_frequency", "gain_margin", "phase_margin"]


def servo(tau=TAU, delay=0) -> SoftwareServo:
    return SoftwareServo(SoftwareServoParams(type="software_servo", technique="sampled_data",
                                             time_constant=tau, computation_delay=delay))


def loop(gain, period, delay=0, tau=TAU, box=None):
    box = box or {"position_gain": (1.0, 200.0), "sampling_period": (period, period)}
    return servo(tau, delay).loop({"position_gain": gain, "sampling_period": period}, box)


def value(name, lp, **options):
    metric = METRICS[name]()
    return float(ca.evalf(ca.MX(exact_value(metric.evaluate(lp, metric.Options(**options)))[0])))


def control_open_loop(gain, period, delay, tau):
    drive = control.tf([1.0], [tau, 1.0, 0.0]) if tau else control.tf([1.0], [1.0, 0.0])
    sampled = control.sample_system(gain * drive, period, method="zoh")
    return sampled * control.tf([1.0], [1.0] + [0.0] * delay, period)


@pytest.mark.parametrize("gain, period, delay, tau", CASES)
def test_margins_and_crossover_agree_with_python_control(gain, period, delay, tau):
    lp = loop(gain, period, delay, tau)
    gm, pm, wg, wc = control.margin(control_open_loop(gain, period, delay, tau))
    assert math.isfinite(gm) and wg < math.pi / period  # a phase crossover below Nyquist
    assert value("gain_margin", lp) == pytest.approx(gm, rel=1e-9)
    assert value("phase_margin", lp) == pytest.approx(pm, abs=1e-9 * 180)
    assert value("crossover_frequency", lp) == pytest.approx(wc, rel=1e-9)


@pytest.mark.parametrize("gain, period, delay, tau", CASES)
def test_peak_and_bandwidth_agree_with_python_control(gain, period, delay, tau):
    closed = control.feedback(control_open_loop(gain, period, delay, tau), 1)
    peak, bandwidth = control_peak_and_bandwidth(closed, period)
    lp = loop(gain, period, delay, tau)
    assert value("m_peak", lp) == pytest.approx(peak, abs=1e-9)
    assert value("bandwidth", lp) == pytest.approx(bandwidth, rel=1e-9)


def test_pulse_transfer_matches_the_state_space_loop():
    """H = N/(D + N) from the pulse transfer L = N/D (what the frequency metrics read)
    equals C(zI − Φ)⁻¹Γ of the loop's closed-loop matrices (what its step integrals and
    poles come from), and L = H/(1 − H), at z = e^{jωT} up to π/T."""
    lp = loop(40.0, 0.005, 1)
    phi = np.array(ca.evalf(lp.state_matrix))
    gamma = np.array(ca.evalf(lp.input_matrix)).ravel()
    for omega in np.geomspace(0.1, math.pi / 0.005, 50):
        z = np.exp(1j * omega * 0.005)
        state_space = np.linalg.solve(z * np.eye(phi.shape[0]) - phi, gamma)[0]
        h_re, h_im = (float(ca.evalf(v)) for v in lp.frequency_response(omega))
        l_re, l_im = (float(ca.evalf(v)) for v in lp.open_loop_response(omega))
        # 1e-10 of |H(1)| = 1: rounding of the complex solve near z = 1 (measured 7.7e-12)
        assert abs(complex(h_re, h_im) - state_space) <= 1e-10
        assert abs(complex(l_re, l_im) - state_space / (1 - state_space)) <= 1e-10 * abs(
            complex(l_re, l_im))


def test_gain_margin_at_the_nyquist_frequency():
    """K/s behind a ZOH without delay: L = KT/(z − 1) is real and negative at z = −1, so
    the phase reaches −180° exactly at π/T and GM = 2/(KT) (the pole 1 − KT reaches −1 at
    twice the gain). python-control's margin does not report a crossing on the band's
    edge (it returns inf), so the closed form is the check."""
    gain, period = 30.0, 0.01
    assert value("gain_margin", loop(gain, period, 0, None)) == pytest.approx(
        2 / (gain * period), rel=1e-9)
    assert sampled_frequency.gain_margin(ServoModel(gain, None, period)) == pytest.approx(
        2 / (gain * period), rel=1e-12)


def test_bandwidth_of_a_loop_that_passes_everything_is_the_nyquist_frequency():
    """Deadbeat: K = 1/T on K/s gives H = 1/z, |H| = 1 at every ω: no −3 dB point below
    π/T, so the bandwidth is π/T (beyond it the discrete loop represents nothing)."""
    period = 0.01
    lp = loop(1 / period, period, 0, None)
    assert value("m_peak", lp) == pytest.approx(1.0, abs=1e-9)
    assert value("bandwidth", lp) == pytest.approx(math.pi / period, rel=1e-9)
    assert sampled_frequency.bandwidth(ServoModel(1 / period, None, period)) == math.pi / period


def test_a_free_period_uses_the_box_band_and_stays_exact():
    """With T free in [1 ms, 20 ms] the band reaches above π/T_min; at T = 1/64 s the
    metrics equal those of the loop with T fixed (grid points above π/T read the aliases
    of the response, which repeat its values, or the crossing functions' cut)."""
    box = {"position_gain": (1.0, 200.0), "sampling_period": (1e-3, 0.02)}
    free = loop(18.0, 1 / 64, 0, TAU, box)
    fixed = loop(18.0, 1 / 64, 0, TAU)
    assert free.frequency_band[1] > math.pi / 1e-3 > fixed.frequency_band[1]
    for name in FREQUENCY:
        assert value(name, free) == pytest.approx(value(name, fixed), rel=1e-9), name


def test_symbolic_period_gives_the_derivative_of_the_exact_metric():
    """d(metric)/dT of the symbolic loop (T an NLP symbol) matches a central difference of
    the exact metric on loops of numbers (step 1e-7 s: truncation (1e-7)²·f‴ and rounding
    1e-15/1e-7 both below 1e-6 relative)."""
    box = {"position_gain": (1.0, 200.0), "sampling_period": (1e-3, 0.02)}
    period = ca.MX.sym("T")
    symbolic = servo(TAU, 1).loop({"position_gain": 40.0, "sampling_period": period}, box)
    h = 1e-7
    for name in ["gain_margin", "phase_margin", "crossover_frequency", "m_peak", "bandwidth"]:
        metric = METRICS[name]()
        expr = ca.MX(exact_value(metric.evaluate(symbolic, metric.Options()))[0])
        derivative = float(ca.Function("d", [period], [ca.jacobian(expr, period)])(0.005))
        upper = value(name, loop(40.0, 0.005 + h, 1, TAU, box))
        lower = value(name, loop(40.0, 0.005 - h, 1, TAU, box))
        assert derivative == pytest.approx((upper - lower) / (2 * h), rel=1e-5), name


# -- step shape ------------------------------------------------------------------------------

def control_step_position(gain, period, delay, tau):
    """(x at the samples, x(t) at any t): the closed loop's samples by python-control's
    step response, between samples the drive discretised by python-control over the
    elapsed part σ of the period, from the sample's drive state and held command."""
    drive = (control.ss(control.tf([1.0], [tau, 1.0, 0.0])) if tau
             else control.ss(control.tf([1.0], [1.0, 0.0])))
    plant = control.sample_system(drive, period, method="zoh")
    command = control.tf([gain], [1.0] + [0.0] * delay, period)  # c(n − d), c = K·e
    closed = control.feedback(command * plant, 1)
    samples = 4000
    # the held command is K·e(n − d); the drive state by simulating the plant on it
    time = np.arange(samples) * period
    position = control.forced_response(closed, time, np.ones(samples)).outputs
    held = gain * np.concatenate([np.zeros(delay), 1.0 - position[:samples - delay]])
    states = control.forced_response(plant, time, held, return_x=True).states.T

    def at(t):
        n = min(int(t // period), samples - 1)
        sigma = t - n * period
        if sigma == 0:
            return float(position[n])
        part = control.sample_system(drive, sigma, method="zoh")
        return float((part.C @ (part.A @ states[n] + part.B[:, 0] * held[n]))[0])

    return time, position, at


@pytest.mark.parametrize("gain, period, delay, tau", CASES)
def test_overshoot_and_settling_time_agree_with_python_control(gain, period, delay, tau):
    """Overshoot: the largest position, between samples too, above the 1 m step; settling
    time: the last time |1 − x| = 2 %. python-control's samples bound both (the intersample
    peak is at least the sampled one; the last exit lies within a period before
    step_info's settling sample); the exact values are polished on python-control's
    intersample position."""
    lp = loop(gain, period, delay, tau)
    overshoot = value("overshoot", lp)
    settling = value("settling_time", lp, band=0.02)
    time, position, at = control_step_position(gain, period, delay, tau)
    closed = control.feedback(control_open_loop(gain, period, delay, tau), 1)
    info = control.step_info(closed, SettlingTimeThreshold=0.02)
    assert overshoot >= info["Overshoot"] / 100 - 1e-12
    assert info["SettlingTime"] - period - 1e-12 <= settling <= info["SettlingTime"] + 1e-12
    # the peak: polished in the periods around the largest sample
    k = int(np.argmax(position))
    peak = max(-minimize_scalar(lambda t: -at(t), bounds=(time[max(k - 1, 0)], time[k + 1]),
                                method="bounded", options={"xatol": 1e-14}).fun,
               float(position[k]))
    assert overshoot == pytest.approx(max(0.0, peak - 1.0), abs=1e-9)
    # the exit: in the period before the sample where step_info says it has settled
    stop = info["SettlingTime"]
    side = math.copysign(0.02, 1.0 - at(stop - period / 2))
    dense = np.linspace(stop - period, stop, 201)
    outside = [t for t in dense if abs(1.0 - at(t)) > 0.02]
    assert outside  # the sample before step_info's settling time is outside the band
    t0 = max(outside)
    exit_time = brentq(lambda t: 1.0 - at(t) - side, t0, t0 + period / 200, xtol=1e-15)
    assert settling == pytest.approx(exit_time, abs=1e-9 * period)


def test_ideal_drive_peaks_at_the_samples():
    """Sato's drive 1/s moves linearly within a period, so its extremes are at the samples:
    the overshoot equals python-control's sampled step_info exactly (to rounding)."""
    gain, period, delay = 30.0, 0.01, 1
    closed = control.feedback(control_open_loop(gain, period, delay, None), 1)
    info = control.step_info(closed)
    assert value("overshoot", loop(gain, period, delay, None)) == pytest.approx(
        info["Overshoot"] / 100, abs=1e-12)


def test_overshoot_and_settling_are_reported_only():
    """Step shape is a numeric response: the NLP may not take it (TypeError on symbols)."""
    period = ca.MX.sym("T")
    box = {"position_gain": (1.0, 200.0), "sampling_period": (1e-3, 0.02)}
    symbolic = servo().loop({"position_gain": 18.0, "sampling_period": period}, box)
    for name in ("overshoot", "settling_time"):
        metric = METRICS[name]()
        assert metric.supports(symbolic, metric.Options()) and not metric.optimisable(symbolic)
        with pytest.raises(TypeError):
            metric.evaluate(symbolic, metric.Options())
    ramp = METRICS["settling_time"].Options(input="ramp")
    assert not METRICS["settling_time"]().supports(symbolic, ramp)


def test_unstable_sampled_loop_never_settles():
    lp = loop(200.0, 0.02, 1)  # K·T = 4 with a sample of delay: poles outside |z| = 1
    assert value("overshoot", lp) == math.inf
    assert value("settling_time", lp) == math.inf


# -- validator -------------------------------------------------------------------------------

@pytest.mark.parametrize("gain, period, delay, tau", CASES)
def test_validator_agrees_with_python_control(gain, period, delay, tau):
    """The validator's own model (expm, grid + Brent) against python-control, to the
    tolerances of the module docstring."""
    model = ServoModel(gain, tau, period, delay)
    gm, pm, _, wc = control.margin(control_open_loop(gain, period, delay, tau))
    closed = control.feedback(control_open_loop(gain, period, delay, tau), 1)
    peak, bandwidth = control_peak_and_bandwidth(closed, period)
    assert sampled_frequency.gain_margin(model) == pytest.approx(gm, rel=1e-9)
    assert sampled_frequency.phase_margin(model) == pytest.approx(pm, abs=1e-9 * 180)
    assert sampled_frequency.crossover(model) == pytest.approx(wc, rel=1e-9)
    assert sampled_frequency.m_peak(model) == pytest.approx(peak, abs=1e-9)
    assert sampled_frequency.bandwidth(model) == pytest.approx(bandwidth, rel=1e-9)


@pytest.mark.parametrize("gain, period, delay, tau", CASES)
def test_validator_sensitivity_peak_agrees_with_python_control(gain, period, delay, tau):
    """M_s = sup |1/(1 + L)| up to π/T: the validator's against python-control's sensitivity
    function evaluated at z = e^{jωT} (the same grid-and-Brent search as for M_peak, with a
    unit DC reference: S(1) = 0 for a type-1 loop, so the peak is read unnormalised), to
    1e-9 of the unit gain, as M_peak."""
    sensitivity = control.feedback(1, control_open_loop(gain, period, delay, tau))
    nyquist = math.pi / period
    grid = np.geomspace(nyquist * 1e-5, nyquist, 20_001)
    mag = np.abs(np.asarray(sensitivity(np.exp(1j * grid * period))).ravel())
    k = int(np.argmax(mag))
    polished = minimize_scalar(
        lambda u: -float(np.abs(sensitivity(np.exp(1j * math.exp(u) * period)))),
        method="bounded", options={"xatol": 1e-12},
        bounds=(math.log(grid[max(k - 1, 0)]), math.log(grid[min(k + 1, grid.size - 1)])))
    expected = max(1.0, float(mag[k]), -polished.fun)
    model = ServoModel(gain, tau, period, delay)
    assert sampled_frequency.sensitivity_peak(model) == pytest.approx(expected, abs=1e-9)
    assert value("sensitivity_peak", loop(gain, period, delay, tau)) == pytest.approx(
        expected, abs=1e-9)


@pytest.mark.parametrize("gain, period, delay, tau", CASES)
def test_validator_step_shape_agrees_with_the_metrics(gain, period, delay, tau):
    model = ServoModel(gain, tau, period, delay)
    lp = loop(gain, period, delay, tau)
    assert sampled_frequency.overshoot(model) == pytest.approx(value("overshoot", lp), abs=1e-9)
    assert sampled_frequency.settling_time(model, 0.02) == pytest.approx(
        value("settling_time", lp, band=0.02), abs=1e-9 * period)


def test_validator_flags_a_wrong_reported_margin():
    """A result whose gain margin is off by 1e-4 relative fails its validation entry; the
    right one passes (the hook in ServoModel.measure reaches this module)."""
    model = ServoModel(40.0, TAU, 0.005, 1)
    right = sampled_frequency.gain_margin(model)
    for reported, ok in ((right, True), (right * (1 + 1e-4), False)):
        result = {"metrics": {"gain_margin": {"metric": "gain_margin", "options": {},
                                              "value": reported, "unit": "1"}}}
        (entry,) = model.measure(result)
        assert entry["metric"] == "gain_margin" and entry["ok"] is ok, json.dumps(entry)


# -- tuning ----------------------------------------------------------------------------------

def tuned(spec: dict):
    from feedtune.problem import tune
    from feedtune.schema.spec import parse_spec
    return tune(parse_spec(spec))


def servo_spec(tunables, objective, constraints, delay=1):
    return {"name": "sampled-frequency",
            "plant": {"type": "software_servo", "technique": "sampled_data",
                      "time_constant": TAU, "computation_delay": delay},
            "tunables": tunables, "objective": objective, "constraints": constraints,
            "solver": {"multistart": 2}}


def test_widest_bandwidth_with_gain_and_period_free():
    """Max bandwidth s.t. M_peak ≤ 1.3, PM ≥ 45°, GM ≥ 2 and T ≥ τ/4, K and T free: the
    peak bound is active (the exchange method holds it within 1e-6, the tuner's feasibility
    tolerance), T sits on its bound (faster sampling only helps), and python-control's
    margins and the validator agree with the reported values."""
    result = tuned(servo_spec(
        {"position_gain": {"min": 1, "max": 200}, "sampling_period": {"min": 0.002, "max": 0.02}},
        [{"metric": "bandwidth", "goal": "maximize"}],
        [{"metric": "m_peak", "max": 1.3}, {"metric": "phase_margin", "min": 45},
         {"metric": "gain_margin", "min": 2}, {"metric": "sampling_ratio", "min": 0.25}]))
    assert result.success
    gain = result.tuned["position_gain"].value
    period = result.tuned["sampling_period"].value
    metrics = {k: m.value for k, m in result.metrics.items()}
    assert metrics["m_peak"] == pytest.approx(1.3, abs=1e-6)
    assert period == pytest.approx(0.25 * TAU, rel=1e-6)
    gm, pm, _, wc = control.margin(control_open_loop(gain, period, 1, TAU))
    assert metrics["gain_margin"] == pytest.approx(gm, rel=1e-9) and gm >= 2
    assert metrics["phase_margin"] == pytest.approx(pm, abs=1e-9 * 180) and pm >= 45 - 1e-6
    assert metrics["crossover_frequency"] == pytest.approx(wc, rel=1e-9)
    entries = {e["metric"]: e for e in result.validation["entries"]}
    for name in FREQUENCY + ["overshoot", "settling_time"]:
        assert entries[name]["ok"], entries[name]


def test_phase_margin_bound_with_the_period_fixed():
    """Min IAE with PM ≥ 60° at Koren's f_s = 64 Hz: the margin bound is active (IAE falls
    with K until the margin binds) and equals python-control's to 1e-9 × 180°."""
    result = tuned(servo_spec(
        {"position_gain": {"min": 1, "max": 200}, "sampling_period": {"value": 1 / 64}},
        [{"metric": "iae"}], [{"metric": "phase_margin", "min": 60}], delay=0))
    assert result.success
    gain = result.tuned["position_gain"].value
    _, pm, _, _ = control.margin(control_open_loop(gain, 1 / 64, 0, TAU))
    assert pm == pytest.approx(60, abs=1e-6 * 180)  # active, to the tuner's tolerance
    assert result.metrics["phase_margin"].value == pytest.approx(pm, abs=1e-9 * 180)


def test_widest_gain_margin_at_a_crossover_with_gain_and_period_free():
    """Max gain margin s.t. crossover ≥ 30 rad/s and T ≥ τ/4, K and T free: a higher
    crossover costs margin, so the crossover bound is active (to the tuner's 1e-6) and T
    sits on its bound (a shorter dead time only helps); python-control agrees."""
    result = tuned(servo_spec(
        {"position_gain": {"min": 1, "max": 200}, "sampling_period": {"min": 0.002, "max": 0.02}},
        [{"metric": "gain_margin", "goal": "maximize"}],
        [{"metric": "crossover_frequency", "min": 30}, {"metric": "sampling_ratio", "min": 0.25}]))
    assert result.success
    gain = result.tuned["position_gain"].value
    period = result.tuned["sampling_period"].value
    assert period == pytest.approx(0.25 * TAU, rel=1e-6)
    gm, _, _, wc = control.margin(control_open_loop(gain, period, 1, TAU))
    assert wc == pytest.approx(30.0, rel=1e-6)
    assert result.metrics["gain_margin"].value == pytest.approx(gm, rel=1e-9)
    assert result.metrics["crossover_frequency"].value == pytest.approx(wc, rel=1e-9)
