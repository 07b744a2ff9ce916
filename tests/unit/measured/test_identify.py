"""Identification of every bundled drive from data simulated with 1 % noise (issue 17 item 1).

The data come from examples/data/make_data.py (python-control's c2d, forced_response and
evalfr, not feedtune's own model), with the noise it documents. The truths come from the
bundled example specs' plant blocks, through the plant classes' own transfer functions.

Tolerances:
- each identified parameter is within 4 of its reported standard errors σ of the truth.
  Under the fit's assumptions an estimate is normal about the truth with that σ, so a
  correct estimator exceeds 4σ with probability 6e-5 per parameter, 0.2 % for the 36
  parameters of this file together; a wrong σ or a biased estimator is caught as soon as
  its error exceeds 4σ, and every σ here is at most 1 % of its value (checked), so a bias
  of 4 % or more always fails;
- :func:`test_standard_error_is_the_spread_of_the_estimates` checks that σ is the real
  spread (40 noise draws, within the ±30 % a 40-sample standard deviation allows at ≈3
  of its own standard errors, 1/√78 ≈ 11 %);
- a tuning on the identified plant gives every tuned value within 2 % of the tuning on
  the true plant (the issue's check).
"""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

from feedtune.measured import models
from feedtune.measured.data import FrequencyResponseData, TimeSeriesData
from feedtune.measured.fit import Structure, band, linear_fit
from feedtune.measured.identify import identify
from feedtune.measured.rational import Rational

REPO = Path(__file__).resolve().parents[3]
_spec = importlib.util.spec_from_file_location("make_data", REPO / "examples/data/make_data.py")
make_data = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(make_data)

#: the same SI relative noise as the bundled example data
NOISE = make_data.NOISE
SIGMAS = 4.0
#: a standard error larger than this fraction of its value would make the 4σ check too weak
MAX_RELATIVE_SIGMA = 0.01


def example(name: str) -> dict:
    return json.loads((REPO / "examples" / f"{name}.json").read_text())


# (model, example spec, drive velocity gain for the software servo, position unit, input
#  unit, frequency band [rad/s], sampling period [s], hold of the random steps [samples])
CASES = {
    "software_servo": (models.software_servo(), "koren-1979-reference-pulse", 0.05, "m", "V",
                       (1.0, 1e3), 1e-3, 20),
    "hydraulic_rotary": (models.hydraulic_rotary(), "bhatia-1971-hydraulic", None, "rad", "V",
                         (1.0, 1e3), 1e-3, 20),
    "ward_leonard": (models.ward_leonard(), "ward-leonard-feed-drive", None, "rad", "V",
                     (0.1, 1e2), 1e-2, 20),
    "linear": (models.linear(2, 2, 2, True), "user-defined-drive", None, "rad", "N·m",
               (2 * np.pi * 5, 2 * np.pi * 2000), 1e-4, 10),
}


def truth(name: str) -> tuple[Rational, tuple, float]:
    """The true position response and the transfer function make_data simulates."""
    model, spec, gain, *_ = CASES[name]
    num, den, dead_time = make_data.velocity_transfer(example(spec)["plant"], gain)
    num = np.trim_zeros(np.asarray(num, float), "b") if name == "linear" else np.asarray(num)
    den = np.trim_zeros(np.asarray(den, float), "b")
    # position = velocity/s; the linear drive's s·P(s) loses its s again (one zero at 0)
    integrators = 2 if name == "linear" else 1
    a0 = den[-1]
    return (Rational(num[::-1] / a0, den[::-1] / a0, integrators, dead_time),
            (list(num), list(den)), dead_time)


def simulated(name: str, kind: str, seed: int, points: int | None = None):
    """A data set of drive ``name``: 'frequency' (position response, 400 points) or 'time'
    (velocity, random steps, 20 000 samples), 1 % noise."""
    model, spec, gain, unit, inp, (lo, hi), period, hold = CASES[name]
    rng = np.random.default_rng(seed)
    rational, (num, den), dead_time = truth(name)
    if name == "linear":  # the velocity transfer is s·P: make_data's form, num·s
        num = num + [0.0]
        den = den + [0.0, 0.0]
    if kind == "frequency":
        omega = np.logspace(np.log10(lo), np.log10(hi), points or 400)
        g = make_data.frequency_response(num, den, dead_time, omega, 0, rng)
        return FrequencyResponseData(omega, g, None, input_unit=inp, output_unit=unit,
                                     source=f"{name}-frf")
    count = points or 20000
    u = make_data.random_steps(count, hold, rng)
    samples = int(round(dead_time / period))
    y = make_data.time_response(num, den, samples, u, period, 1, rng)
    return TimeSeriesData(np.arange(count) * period, u, y, input_unit=inp, output_unit=f"{unit}/s",
                          source=f"{name}-time")


@pytest.fixture(scope="module")
def identified():
    """``identified(name, kind)``: (the seed-17 data set of :func:`simulated`, its
    identification by the case's model), made once per module: three tests read the same
    one (the linear frequency response, the hydraulic time series). Read it, do not change
    it."""
    made = {}

    def get(name: str, kind: str):
        if (name, kind) not in made:
            data = simulated(name, kind, seed=17)
            made[name, kind] = data, identify([data], CASES[name][0])
        return made[name, kind]

    return get


def true_values(name: str) -> np.ndarray:
    rational, _, _ = truth(name)
    return CASES[name][0].values(rational.numerator, rational.denominator, rational.dead_time)


@pytest.mark.parametrize("kind", ["frequency", "time"])
@pytest.mark.parametrize("name", list(CASES))
def test_identified_within_their_standard_errors(name, kind, identified):
    data, result = identified(name, kind)
    expected = true_values(name)
    for (parameter, value), want in zip(result.values.items(), expected):
        sigma = result.standard_errors[parameter]
        assert 0 < sigma <= MAX_RELATIVE_SIGMA * abs(want) or parameter == "numerator_s1", (
            parameter, sigma, want)
        assert abs(value - want) <= SIGMAS * sigma, (parameter, value, want, sigma)
    # the output error of a model near the truth is the noise: NRMSE ≈ 1 % (of the RMS, so
    # of a time series NRMSE ≈ 1 %·RMS/std); 20 % covers the noise draw's own spread
    noise = NOISE if kind == "frequency" else NOISE * np.sqrt(np.mean(data.output ** 2)) / np.std(
        data.output)
    assert result.fit.nrmse[0] == pytest.approx(noise, rel=0.2)


def test_linear_numerator_s1_is_weakly_determined_but_consistent(identified):
    """b_1 of the two-mass drive (0.0462/6 N·m⁻¹·rad·s⁻¹) only shapes the anti-resonance's
    damping: its σ is ≈ 0.4 % from the frequency data, 40 % from the time data, and
    within 4σ of the truth in both (the test above)."""
    _, result = identified("linear", "frequency")
    assert result.standard_errors["numerator_s1"] <= 0.01 * result.values["numerator_s1"]


def test_several_data_sets_of_one_axis_are_fitted_together():
    """Two frequency responses and a time series of the hydraulic drive: one model, each
    set's NRMSE near its noise, the estimate within 4σ."""
    data = [simulated("hydraulic_rotary", "frequency", seed=1),
            simulated("hydraulic_rotary", "frequency", seed=2),
            simulated("hydraulic_rotary", "time", seed=3, points=5000)]
    result = identify(data, models.hydraulic_rotary())
    for value, want, parameter in zip(result.values.values(), true_values("hydraulic_rotary"),
                                      result.values):
        assert abs(value - want) <= SIGMAS * result.standard_errors[parameter]
    assert len(result.fit.nrmse) == 3
    assert all(0.5 * NOISE < n < 2 * NOISE for n in result.fit.nrmse)


def test_standard_error_is_the_spread_of_the_estimates():
    """40 noise draws of the software servo's frequency response (100 points): the
    reported σ of τ is the standard deviation of the estimates within ±30 %."""
    model = models.software_servo()
    estimates, sigmas = [], []
    for seed in range(40):
        result = identify([simulated("software_servo", "frequency", seed, points=100)], model)
        estimates.append(result.values["time_constant"])
        sigmas.append(result.standard_errors["time_constant"])
    ratio = np.std(estimates, ddof=1) / np.mean(sigmas)
    assert 0.7 < ratio < 1.3, ratio


def test_equation_error_alone_is_biased_on_noisy_time_data(identified):
    """Why the output-error stage runs: the state-variable-filter equation error of the
    hydraulic drive's velocity (1 % noise) is off the truth by many output-error σ (the
    noise enters its regressors), the output-error estimate is not."""
    data, result = identified("hydraulic_rotary", "time")
    data = [data]
    model = models.hydraulic_rotary()
    lo, hi = band(data)
    omega0 = float(np.sqrt(lo * hi))
    x, _ = linear_fit(data, model.structure, omega0, None)
    linear = model.structure.rational(x, omega0)
    first = model.values(linear.numerator, linear.denominator, 0.0)
    sigma = np.array(list(result.standard_errors.values()))
    assert np.max(np.abs(first - true_values("hydraulic_rotary")) / sigma) > 10 * SIGMAS


def test_rational_simulation_is_exact_with_a_fractional_dead_time():
    """The model's held-input response with θ = 2.5 samples equals python-control's
    c2d at half the period with a 5-sample delay (the same continuous system, exact at
    every sample: both are zero-order-hold discretisations) to 1e-9 of its range."""
    import control

    period = 1e-3
    rng = np.random.default_rng(0)
    u = rng.standard_normal(300)
    model = Rational(np.array([2.0, 0.001]), np.array([1.0, 0.02, 1e-4]), 1, 2.5 * period)
    y = model.simulate(u, period)
    sys = control.c2d(control.tf([0.001, 2.0], [1e-4, 0.02, 1.0, 0.0]), period / 2, "zoh")
    fine = np.concatenate([np.zeros(5), np.repeat(u, 2)])[:600]
    reference = control.forced_response(sys, U=fine).outputs[::2]
    assert np.max(np.abs(y - reference)) <= 1e-9 * np.ptp(reference)


# ---------------------------------------------------------------- tuning on the result


def tuning_spec(name: str) -> dict:
    """The example spec of drive ``name``; for Ward-Leonard its gains alone (compensators
    none, M_peak ≤ 1.3, widest bandwidth): the example's optimum is flat along its lag-lead
    time constants (τ1 = τ2 there: no compensator at all), so a 0.1 % change of the plant
    moved K'_v from 1000 to 906 V·s/rad at bandwidths 0.004 % apart, which says nothing of
    the identification."""
    model, spec_name = CASES[name][:2]
    spec = example(spec_name)
    if name == "ward_leonard":
        spec["plant"].update(velocity_compensator="none", position_compensator="none")
        spec.update(tunables={"position_gain": {"min": 0.1, "max": 1000, "initial": 1},
                              "velocity_gain": {"min": 0.1, "max": 1000, "initial": 10}},
                    constraints=[{"metric": "m_peak", "max": 1.3}], solver={"multistart": 4})
    return spec


@pytest.mark.parametrize("name", list(CASES))
def test_tuning_on_the_identified_plant_matches_the_true_plant(name):
    """The example spec of each drive, its plant replaced by the identified block (written
    over the spec's own plant as template: compensators, controllers, technique), tunes
    to values within 2 % of the true plant's tuning."""
    from feedtune.api import tune

    model = CASES[name][0]
    spec = tuning_spec(name)
    result = identify([simulated(name, "frequency", seed=5)], model, template=spec["plant"])
    identified = dict(spec, plant=result.plant)
    true_tuned, ident_tuned = tune(spec), tune(identified)
    assert true_tuned.success and ident_tuned.success
    for tunable, value in true_tuned.values.items():
        assert ident_tuned.values[tunable] == pytest.approx(value, rel=0.02), tunable


def test_sign_constrained_least_squares_against_scipy():
    """The linear stage's constrained least squares (cvxpy, Clarabel) on a problem whose
    unconstrained minimiser has a negative a_1 equals scipy's bounded lsq_linear to 1e-7
    relative: Clarabel's default tolerances are 1e-8 on the optimality gap."""
    from scipy.optimize import lsq_linear

    from feedtune.measured.fit import _constrained_lstsq

    rng = np.random.default_rng(4)
    phi = rng.standard_normal((200, 4))
    target = phi @ np.array([-1.0, 2.0, 0.5, -3.0]) + 0.1 * rng.standard_normal(200)
    structure = Structure(zeros=1, poles=2, integrators=1, dead_time=False, positive_gain=True)
    x = _constrained_lstsq(phi, target, structure)
    reference = lsq_linear(phi, target, bounds=([0, 0, 0, -np.inf], np.inf), tol=1e-12).x
    assert x[0] == pytest.approx(0.0, abs=1e-7)  # the active constraint a_1 ≥ 0
    np.testing.assert_allclose(x, reference, rtol=1e-7, atol=1e-7)


@pytest.mark.parametrize("name", ["hydraulic_rotary", "ward_leonard"])
def test_lumped_block_of_the_true_constants_is_the_same_drive(name):
    """The block written from the true identifiable constants (lumped as models.py says)
    has the example plant's velocity per volt at every frequency, to 1e-12 relative (the
    rounding of the roots of a(s) that read the named parameters), so a tuning cannot
    tell them apart."""
    from feedtune.plants import PLANTS

    model, spec_name = CASES[name][:2]
    true_block = example(spec_name)["plant"]
    rational, _, _ = truth(name)
    values = dict(zip(model.parameters({"position": "rad", "input": "V"}),
                      model.values(rational.numerator, rational.denominator, 0.0)))
    lumped = model.block(values, {"position": "rad", "input": "V"}, true_block)

    def velocity_per_volt(block, s):
        drive = PLANTS[name](PLANTS[name].Params.model_validate(block))
        num, d1, d2 = drive.velocity_per_volt()
        return np.polyval(num, s) / (np.polyval(d1, s) * np.polyval(d2, s))

    s = 1j * np.logspace(-2, 4, 200)
    np.testing.assert_allclose(velocity_per_volt(lumped, s), velocity_per_volt(true_block, s),
                               rtol=1e-12)
