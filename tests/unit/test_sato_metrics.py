"""Sato's software servo and circle formulas against closed forms and their limits.

* The ideal-drive sampled loop (one-sample delay) and the Padé model (Sato eq 5) against
  polynomials and frequency responses built here with numpy.
* average_radius (eq 3) against the polygon's area (eq 2); radius_decrease (eq 7) and
  surface_roughness (eq 10, Table 1) against their structure and limits: T → 0, |G| ≡ 1,
  monotonicity in T and K_p.
* Spec rules of the new plant options.
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from feedtune.loops.loop import Interpolator
from feedtune.objectives import METRICS
from feedtune.objectives.contour.circle import CircleOptions
from feedtune.objectives.contour.radial_error import RadialError
from feedtune.objectives.contour.surface_roughness import TABLE_1, TABLE_1_Q, table_1_coefficients
from feedtune.plants.software_servo import SoftwareServo, SoftwareServoParams
from feedtune.schema.spec import SpecError, parse_spec
from expression_values import as_number

CIRCLE = CircleOptions(radius=0.05, feed=0.05)  # Sato's circle: 50 mm at 1 rad/s
OMEGA = 1.0


def sato_servo(model="exact", time_constant=None, delay=1) -> SoftwareServo:
    return SoftwareServo(SoftwareServoParams(
        type="software_servo", technique="sampled_data", time_constant=time_constant,
        computation_delay=delay, model=model, interpolation="linear"))


def sato_loop(model="exact", gain=40.0, period=0.002, interval=0.13, **kwargs):
    servo = sato_servo(model, **kwargs)
    box = {name: (t.min, t.max) for name, t in servo.tunables().items()}
    values = {"position_gain": gain, "sampling_period": period, "reference_interval": interval}
    return servo.loop(values, box)


def metric(name, loop, options=CIRCLE) -> float:
    return as_number(METRICS[name]().evaluate(loop, options))


# -- the loops ---------------------------------------------------------------------------------

def delayed_integrator(omega, gain, period):
    """G(e^{jωΔt}) = KΔt/(z² − z + KΔt) of the exact loop."""
    z = np.exp(1j * omega * period)
    return gain * period / (z * z - z + gain * period)


def pade(omega, gain, period):
    """G(jω) of Sato eq 5, L = 1.5 Δt_p."""
    s, dead = 1j * omega, 1.5 * period
    return gain * (2 / dead - s) / (s * s + (2 / dead - gain) * s + 2 * gain / dead)


def test_exact_loop_is_the_delayed_integrator():
    # x(n+1) = x(n) + Δt·K(r − x(n−1)): z² − z + KΔt, G(z) = KΔt/(z² − z + KΔt)
    k, dt = 40.0, 0.002
    loop = sato_loop("exact", k, dt)
    assert loop.order == 2 and loop.discrete and not loop.has_exact_step_error
    poly = [as_number(c) for c in loop.characteristic_polynomial]
    np.testing.assert_allclose(poly, [1, -1, k * dt], rtol=1e-14)
    for omega in (1.0, 48.3, 700.0):
        re, im = loop.frequency_response(omega)
        # the loop solves (zI − Φ)x = Γ at z = e^{jωΔt} near 1, conditioned as 1/(ωΔt)²
        np.testing.assert_allclose(as_number(re) + 1j * as_number(im), delayed_integrator(omega, k, dt),
                                   rtol=1e-9)


def test_pade_loop_is_eq5():
    # Sato eq 5: G = K_p(2/L − s)/(s² + (2/L − K_p)s + 2K_p/L), L = 1.5 Δt_p; its gain is
    # eq 6 with the numerator K_p²ω² + (2K_p/L)² (docs/errata.md)
    k, dt = 40.0, 0.002
    dead = 1.5 * dt
    loop = sato_loop("pade", k, dt)
    poly = [as_number(c) for c in loop.characteristic_polynomial]
    np.testing.assert_allclose(poly, [1, 2 / dead - k, 2 * k / dead], rtol=1e-14)
    assert as_number(loop.velocity_constant) == pytest.approx(k, rel=1e-15)
    for omega in (1.0, 24.0, 300.0):
        expected = pade(omega, k, dt)
        re, im = loop.frequency_response(omega)
        np.testing.assert_allclose(as_number(re) + 1j * as_number(im), expected, rtol=1e-12)
        eq6 = math.sqrt(((k * omega) ** 2 + (2 * k / dead) ** 2)
                        / ((2 * k / dead - omega**2) ** 2 + ((2 / dead - k) * omega) ** 2))
        assert abs(expected) == pytest.approx(eq6, rel=1e-12)


def test_pade_with_a_drive_time_constant_and_no_delay():
    # Koren's drive K/(s(1 + sτ)) with L = Δt_p/2 (the hold alone): open loop
    # K(1 − Ls/2)/(s(1 + sτ)(1 + Ls/2)), closed by unity feedback
    k, dt, tau = 20.0, 0.01, 0.02
    servo = SoftwareServo(SoftwareServoParams(type="software_servo", technique="sampled_data",
                                              time_constant=tau, model="pade"))
    box = {name: (t.min, t.max) for name, t in servo.tunables().items()}
    loop = servo.loop({"position_gain": k, "sampling_period": dt}, box)
    assert "reference_interval" not in servo.tunables() and loop.interpolator is None
    half = dt / 4
    expected = np.polyadd(np.polymul(np.polymul([half, 1], [tau, 1]), [1, 0]), [-k * half, k])
    poly = [as_number(c) for c in loop.characteristic_polynomial]
    np.testing.assert_allclose(poly, expected / expected[0], rtol=1e-13)


def test_interpolator_carries_t_and_q():
    loop = sato_loop("pade", period=0.002, interval=0.13)
    assert isinstance(loop.interpolator, Interpolator)
    assert as_number(loop.interpolator.steps_per_interval) == pytest.approx(65, rel=1e-15)


# -- eq 3 -------------------------------------------------------------------------------------

@pytest.mark.parametrize("sides", [3, 4, 24, 1000])
def test_average_radius_has_the_polygons_area(sides):
    # eq 2: the polygon is N triangles r² cos(θ/2) sin(θ/2), θ = 2π/N; eq 3: π r̄² equals it
    interval = 2 * math.pi / (sides * OMEGA)  # eq 1
    area = sides * CIRCLE.radius**2 * math.cos(math.pi / sides) * math.sin(math.pi / sides)
    value = metric("average_radius", sato_loop(interval=interval))
    assert math.pi * value**2 == pytest.approx(area, rel=1e-13)


# -- eq 7 -------------------------------------------------------------------------------------

@pytest.mark.parametrize("model, response", [("exact", delayed_integrator), ("pade", pade)])
def test_radius_decrease_is_eq7(model, response):
    loop = sato_loop(model, gain=40.0, period=0.002, interval=0.2)
    average = CIRCLE.radius * math.sqrt(math.sin(0.2) / 0.2)
    expected = CIRCLE.radius - average * abs(response(OMEGA, 40.0, 0.002))
    assert metric("radius_decrease", loop) == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("model", ["exact", "pade"])
def test_radius_decrease_tends_to_the_radial_error_as_t_goes_to_zero(model):
    # r̄ → r as T → 0, so Δr → r(1 − |G(jω)|): the loop's own radial error, in Sato's sign
    # (positive when the circle shrinks). At T = 1 µs, r − r̄ = r(ωT)²/12 ≈ 4e-15 m.
    loop = sato_loop(model, interval=1e-6)
    radial = as_number(RadialError().evaluate(loop, CIRCLE))  # r(|G| − 1), signed
    assert radial < 0
    assert metric("radius_decrease", loop) == pytest.approx(-radial, rel=1e-6)


# -- Table 1, eq 10 ---------------------------------------------------------------------------

def test_table1_rows_beyond_and_between():
    for q, row in zip(TABLE_1_Q, TABLE_1):
        np.testing.assert_allclose([as_number(c) for c in table_1_coefficients(q)], row, atol=1e-12)
    # q beyond the table: the q = 50 row; below q = 2: the q = 2 row
    for q, row in ((65, TABLE_1[-1]), (1e4, TABLE_1[-1]), (1.0, TABLE_1[0])):
        np.testing.assert_allclose([as_number(c) for c in table_1_coefficients(q)], row, atol=1e-12)
    # between rows: linear in 1/q, so q = 20/3 lies a third of the way from q = 5 to q = 10
    between = [as_number(c) for c in table_1_coefficients(20 / 3)]
    np.testing.assert_allclose(between, np.array(TABLE_1[3]) + (np.array(TABLE_1[4])
                                                                - np.array(TABLE_1[3])) / 2,
                               atol=1e-12)


def test_table1_coefficients_are_continuous_in_q():
    qs = np.geomspace(1.5, 80, 2000)
    table = np.array([[as_number(c) for c in table_1_coefficients(q)] for q in qs])
    assert np.abs(np.diff(table, axis=0)).max() < 0.01  # no jumps between rows


class _AllPass:
    """A loop with |G| ≡ 1 (and an interpolator): eq 10 reduces to sagitta × Σ l_{q,k}."""

    def __init__(self, interval, period):
        self.interpolator = Interpolator(interval, period)

    def frequency_response(self, omega):
        return ca.cos(omega), ca.sin(omega)


@pytest.mark.parametrize("q", [2, 3, 5, 20, 130])
def test_surface_roughness_of_a_unit_gain_loop_is_the_sagitta_times_table1(q):
    interval = 0.13
    loop = _AllPass(interval, interval / q)
    sagitta = CIRCLE.radius * (1 - math.cos(OMEGA * interval / 2))
    row = TABLE_1[TABLE_1_Q.index(min(q, 50))]
    assert metric("surface_roughness", loop) == pytest.approx(sagitta * sum(row), rel=1e-12)


@pytest.mark.parametrize("model", ["exact", "pade"])
def test_shorter_reference_interval_gives_a_truer_circle(model):
    # Sato §3: r̄ < r falls with T; Δr and Δm grow with it (larger polygon, slower ripple
    # that the loop passes more of). T from 20 ms to 1 s (q ≥ 10), K_p = 40 1/s,
    # Δt_p = 2 ms. At q < 10 Table 1's rows change shape and Δm need not be monotonic.
    intervals = np.geomspace(0.02, 1.0, 25)
    for name, sign in (("average_radius", -1), ("radius_decrease", 1), ("surface_roughness", 1)):
        values = [metric(name, sato_loop(model, interval=t)) for t in intervals]
        assert np.all(sign * np.diff(values) > 0), name
    assert metric("average_radius", sato_loop(model, interval=0.02)) < CIRCLE.radius


@pytest.mark.parametrize("model", ["exact", "pade"])
def test_gain_trades_radius_decrease_for_roughness(model):
    # A faster loop follows the circle better (Δr falls) and passes more of the polygon's
    # ripple (Δm grows): K_p from 1 to 100 1/s, K_pΔt_p ≤ 0.2 (well damped).
    gains = np.geomspace(1.0, 100.0, 20)
    decrease = [metric("radius_decrease", sato_loop(model, gain=k)) for k in gains]
    roughness = [metric("surface_roughness", sato_loop(model, gain=k)) for k in gains]
    assert np.all(np.diff(decrease) < 0) and np.all(np.diff(roughness) > 0)


def test_circle_metrics_need_an_interpolator():
    servo = SoftwareServo(SoftwareServoParams(type="software_servo", technique="sampled_data",
                                              time_constant=None, computation_delay=1))
    box = {name: (t.min, t.max) for name, t in servo.tunables().items()}
    loop = servo.loop({"position_gain": 40.0, "sampling_period": 0.002}, box)
    for name in ("average_radius", "radius_decrease", "surface_roughness"):
        assert not METRICS[name]().supports(loop, CIRCLE)


# -- spec rules ---------------------------------------------------------------------------------

def _spec(**plant) -> dict:
    return {"name": "sato", "plant": {"type": "software_servo", "technique": "sampled_data",
                                      "time_constant": None, **plant},
            "objective": [{"metric": "surface_roughness", "radius": 0.05, "feed": 0.05}]}


@pytest.mark.parametrize("field, value", [("model", "pade"), ("interpolation", "linear"),
                                          ("time_constant", None)])
def test_sampling_options_are_refused_with_reference_pulse(field, value):
    plant = {"technique": "reference_pulse", "time_constant": 0.02, field: value}
    with pytest.raises(SpecError) as error:
        parse_spec(_spec(**plant))
    assert any(pointer == "/plant" and field in message for pointer, message in error.value.errors)


def test_roughness_without_an_interpolator_names_the_metric():
    with pytest.raises(SpecError) as error:
        parse_spec(_spec(computation_delay=1))
    assert error.value.errors[0][0] == "/objective/0/metric"


def test_time_constant_must_be_given_or_null():
    spec = _spec(interpolation="linear")
    del spec["plant"]["time_constant"]
    with pytest.raises(SpecError) as error:
        parse_spec(spec)
    assert error.value.errors[0][0] == "/plant/time_constant"
