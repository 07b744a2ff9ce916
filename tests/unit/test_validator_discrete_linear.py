"""The validator's model of the ``linear`` loop with a discrete drive (``model.period``,
feedtune/validate/sampled_linear.py): Koren's drive K/(s(1 + sτ)) given in z as its
zero-order-hold equivalent (``control.c2d``, as a transfer function and as state space)
must give the numbers of the same drive given in s with ``implementation: sampled`` at
the same period, whose model discretises it itself; and python-control, closing the
discrete loop its own way (``control.feedback`` of C(z)·z^{−(c+d)}·P(z)), must give its
margins, M_p and bandwidth.

Tolerances: the z and s models are the same rational functions of z reached by two roads
(c2d's expm of python-control's realisation, rounded to the spec's coefficients, against
scipy's expm of the validator's balanced realisation). Measured on these cases: L and H
within 1.8e-10 relative (at 0.1 rad/s, where the type-2 loops' |L| ~ 1e4 carries the
rounding of their double pole at z = 1), the margins, crossover, M_p, bandwidth and radial
error within 5e-12, the poles within 1e-13 and C_v's ramp error within 5e-14 rad. The
asserted 1e-9 is 1000× below the validator's own tolerance (1e-6 relative,
feedtune/validate/tolerances.py), so two models that could disagree on a result cannot
pass. Against python-control: L within 1.2e-11 (asserted 1e-8), M_p and bandwidth within
6e-14 (1e-9), the margins within 2e-9 (1e-7: its frequency-response fallback, as in
tests/unit/test_validator_sampled_linear.py).
"""

from __future__ import annotations

import math

import control
import numpy as np
import pytest

from discrete_checks import control_peak_and_bandwidth
from feedtune.validate import sampled_frequency
from feedtune.validate.linear import LinearModel
from feedtune.validate.model import NotCovered
from feedtune.validate.sampled_linear import SampledLinearModel

#: Koren's drive K/(s(1 + sτ)), K = 1 rad/(V·s), τ = 0.01 s, and the period T
GAIN, TAU, PERIOD = 1.0, 0.01, 1e-3
CONTINUOUS = {"type": "transfer_function", "numerator": [GAIN], "denominator": [TAU, 1.0, 0.0]}
REL = 1e-9  # see the module docstring

#: (plant options in s, the same in z, tuned values): P; P with a computation delay and a
#: dead time of two samples; PI (Tustin and backward Euler)
CASES = {
    "p": ({}, {}, {"position_controller.kp": 30.0}),
    "p-delay1-dead2": ({"computation_delay": 1, "dead_time": 2 * PERIOD},
                       {"computation_delay": 1, "dead_time_samples": 2},
                       {"position_controller.kp": 20.0}),
    "pi-tustin": ({"position_controller": "pi"}, {"position_controller": "pi"},
                  {"position_controller.kp": 20.0, "position_controller.ti": 0.2}),
    "pi-backward": ({"position_controller": "pi", "discretisation": "backward_euler"},
                    {"position_controller": "pi", "discretisation": "backward_euler"},
                    {"position_controller.kp": 20.0, "position_controller.ti": 0.2}),
}


def discrete_drive(form: str) -> dict:
    """Koren's drive as ``control.c2d`` (ZOH) gives it, as a spec's model in z."""
    system = control.c2d(control.tf(CONTINUOUS["numerator"], CONTINUOUS["denominator"]),
                         PERIOD, "zoh")
    if form == "transfer_function":
        num, den = (np.ravel(x).tolist() for x in control.tfdata(system))
        return {"type": form, "period": PERIOD, "numerator": num, "denominator": den}
    space = control.ss(system)
    return {"type": form, "period": PERIOD,
            **{k: np.atleast_2d(getattr(space, k.upper())).tolist() for k in "abc"}}


def plant_of(model: dict, options: dict) -> dict:
    return {"type": "linear", "model": model, "input_unit": "V", "output_unit": "rad",
            "implementation": "sampled", **options}


def models(case: str, form: str) -> tuple[SampledLinearModel, SampledLinearModel]:
    """(the drive given in z, the same drive given in s and sampled)."""
    in_s, in_z, tuned = CASES[case]
    discrete = LinearModel.from_result(plant_of(discrete_drive(form), in_z), tuned)
    sampled = LinearModel.from_result(plant_of(CONTINUOUS, in_s),
                                      {**tuned, "sampling_period": PERIOD})
    return discrete, sampled


def near(a: float, b: float, rel: float = REL) -> bool:
    return abs(a - b) <= rel * abs(b)


PAIRS = [(case, form) for case in sorted(CASES) for form in ("transfer_function",
                                                              "state_space")]


@pytest.mark.parametrize("case, form", PAIRS)
def test_a_drive_in_z_is_the_same_loop_as_its_drive_in_s_sampled(case, form):
    discrete, sampled = models(case, form)
    assert discrete.discrete and not sampled.discrete
    assert discrete.period == PERIOD
    omega = np.geomspace(0.1, math.pi / PERIOD, 41)
    lo_z, h_z = discrete.frequency_response(omega)
    lo_s, h_s = sampled.frequency_response(omega)
    np.testing.assert_allclose(lo_z, lo_s, rtol=REL)
    np.testing.assert_allclose(h_z, h_s, rtol=REL)
    nonzero = [np.sort_complex(p[np.abs(p) > 1e-9]) for p in (discrete.poles(), sampled.poles())]
    np.testing.assert_allclose(*nonzero, atol=1e-9)  # on the unit circle's scale
    assert discrete.loop_type() == sampled.loop_type()
    for measure in (sampled_frequency.m_peak, sampled_frequency.bandwidth,
                    sampled_frequency.phase_margin, sampled_frequency.crossover):
        assert near(measure(discrete), measure(sampled)), measure.__name__
    assert near(sampled_frequency.gain_margin(discrete, discrete.loop_type()),
                sampled_frequency.gain_margin(sampled, sampled.loop_type()))
    # e_ss ~ 1e-2 rad, or 0 for the type-2 PI loops, where both show rounding ~1e-15 rad:
    # 1e-12 rad is far below an encoder count (2^20 per turn: 6e-6 rad)
    ramp = sampled.ramp_following_error()
    assert abs(discrete.ramp_following_error() - ramp) <= REL * abs(ramp) + 1e-12
    # a 10 mm circle at 50 mm/s: an error of ~1e-6 m, compared to 1e-9 of itself
    assert near(discrete.radial_error(0.01, 0.05), sampled.radial_error(0.01, 0.05))


def control_open_loop(case: str, form: str):
    """L(z) = C(z)·z^{−(c+d)}·P(z) by python-control from the spec's own numbers."""
    in_s, in_z, tuned = CASES[case]
    model = discrete_drive(form)
    if form == "transfer_function":
        drive = control.tf(model["numerator"], model["denominator"], PERIOD)
    else:
        drive = control.ss(*(np.array(model[k]) for k in "abc"), 0, PERIOD)
    kp = tuned["position_controller.kp"]
    law = control.tf([kp], [1.0], PERIOD)
    if in_z.get("position_controller") == "pi":  # k_p(1 + 1/(T_i s)), Tustin or backward
        ti = tuned["position_controller.ti"]
        method = {"tustin": "tustin", "backward_euler": "backward_diff"}[
            in_z.get("discretisation", "tustin")]
        law = control.c2d(kp * control.tf([ti, 1.0], [ti, 0.0]), PERIOD, method)
    lag = in_z.get("computation_delay", 0) + in_z.get("dead_time_samples", 0)
    delay = control.tf([1.0], [1.0] + [0.0] * lag, PERIOD)
    # in state space: a product of transfer functions puts the PI's and the drive's poles
    # at z = 1 into one polynomial, whose evaluation near z = 1 loses ~1e-7 to cancellation
    return control.series(*(control.ss(block) for block in (law, delay, drive)))


@pytest.mark.parametrize("case, form", PAIRS)
def test_the_discrete_loop_is_python_controls(case, form):
    """Margins by control.stability_margins (its crossings of the discrete loop up to
    π/T), M_p and bandwidth of control.feedback(L)."""
    discrete, _ = models(case, form)
    open_loop = control_open_loop(case, form)
    omega = np.geomspace(0.1, math.pi / PERIOD, 41)
    np.testing.assert_allclose(discrete.open_loop(omega),
                               open_loop(np.exp(1j * omega * PERIOD)), rtol=1e-8)
    gm, pm, _, _, wgc, _ = control.stability_margins(open_loop)
    assert near(sampled_frequency.gain_margin(discrete, discrete.loop_type()), gm, 1e-7)
    assert near(sampled_frequency.phase_margin(discrete), pm, 1e-7)
    assert near(sampled_frequency.crossover(discrete), wgc, 1e-7)
    peak, bandwidth = control_peak_and_bandwidth(control.feedback(open_loop), PERIOD)
    assert near(sampled_frequency.m_peak(discrete), peak, 1e-9)
    assert near(sampled_frequency.bandwidth(discrete), bandwidth, 1e-9)


def test_a_discrete_drive_has_no_intersample_response():
    """The step integrals are refused (the loop reports none); the report's step response
    is the position at the samples, the s model's at those instants."""
    discrete, sampled = models("p", "transfer_function")
    with pytest.raises(NotCovered, match="between samples"):
        discrete.error_integrals()
    step = discrete.responses()["step"]
    assert np.allclose(np.diff(step.time), PERIOD, rtol=0, atol=1e-15)
    states, _, _ = sampled.step_samples()
    at_samples = states @ sampled.position_row()
    count = min(at_samples.size, step.position.size)
    # positions of ~1 rad: agreement to 1e-9 rad, far below an encoder count (6e-6 rad)
    np.testing.assert_allclose(step.position[:count], at_samples[:count], rtol=0, atol=1e-9)
