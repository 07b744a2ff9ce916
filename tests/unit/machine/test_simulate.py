"""Exact multi-axis simulation (feedtune/machine/simulate.py, run.py).

Checks: the blocked simulation is the per-sample state recursion; two identical axes on a
circle give the single-axis ``radial_error`` metric; mismatched axes on lines give the
closed form of docs/design.md ("Multi-axis contouring"); Koren's cross-coupled controller
reduces that error.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from feedtune.machine.run import axis_loop, builtin_path, nominal_setting, run
from feedtune.machine import simulate as machine_simulate
from feedtune.machine.path import Arc, Line, Path, SegmentTable
from feedtune.machine.run import axis_models, path_direction
from feedtune.machine.simulate import (CrossCoupling, discretise, simulate_coupled,
                                       simulate_coupled_stepped, simulate_lti)
from feedtune.machine.spec import parse_machine
from feedtune.objectives.contour.circle import CircleOptions
from feedtune.objectives.contour.radial_error import RadialError
from feedtune.expr import to_float

#: Koren 1979's drive: τ = 20 ms (his design example)
TAU = 0.02
#: the steady contour errors compared here are 1e-6…1e-3 m; the transient left after the
#: settling samples is below ρ^n of the slowest mode (< 1e-12 of the feed step), so a
#: nanometre (1/5000 of Koren's 5 µm BLU) is far above the rounding and far below the error
NANOMETRE = 1e-9


def machine(technique="sampled_data", gains=(20.0, 20.0), period=1e-3, path=None,
            cross_coupling=None, **extra):
    axes = {name: {"plant": {"type": "software_servo", "technique": technique,
                             "time_constant": TAU},
                   "tunables": {"position_gain": {"value": k}}}
            for name, k in zip("xy", gains)}
    raw = {"name": "test", "axes": axes, "sampling_period": {"value": period}, **extra}
    if path is not None:
        raw["path"] = path
    if cross_coupling is not None:
        raw["cross_coupling"] = cross_coupling
    return parse_machine(raw)


def test_blocked_simulation_is_the_state_recursion():
    """Random stable 4-state system, 1000 samples, two inputs, blocks of 64 (not a
    divisor): equal to the per-sample recursion to rounding (1e-12 of the output's size)."""
    rng = np.random.default_rng(7)
    a = rng.normal(size=(4, 4))
    a *= 0.9 / max(abs(np.linalg.eigvals(a)))
    g, c, d = rng.normal(size=(4, 2)), rng.normal(size=4), rng.normal(size=2)
    u = rng.normal(size=(1000, 2))
    x0 = rng.normal(size=4)
    y = simulate_lti(a, g, c, d, u, x0=x0)
    x, expected = x0.copy(), np.empty(1000)
    for k in range(1000):
        expected[k] = c @ x + d @ u[k]
        x = a @ x + g @ u[k]
    assert np.max(np.abs(y - expected)) <= 1e-12 * np.max(np.abs(expected))


def test_first_order_hold_is_exact_for_a_ramp():
    """A continuous loop discretised with the first-order hold follows a ramp exactly at
    the samples: K/(s(1+sτ)) has steady lag V/K (type 1), reached after the transient."""
    k, v, period = 25.0, 0.1, 1e-3
    a = np.array([[0, 1], [-k / TAU, -1 / TAU]])
    b = np.array([0, k / TAU])
    model = discretise(a, b, [1, 0], 0, 0.0, period)
    t = np.arange(3000) * period
    r = v * t
    u = np.column_stack([r, np.append(r[1:], r[-1] + v * period)])
    y = simulate_lti(model.phi, model.gamma[:, :2], model.c, np.zeros(2), u)
    assert abs((r - y)[-1] - v / k) < NANOMETRE


@pytest.mark.parametrize("feed", [0.04, 0.4])
def test_identical_axes_on_a_circle_give_the_radial_error(feed):
    """Koren's sampled loop (K = 20 1/s, τ = 20 ms, T = 1 ms) on both axes, a circle of
    8 mm (his example) at 0.04 and 0.4 m/s at constant feed, turning until 1.2 s (60 τ)
    have passed before the last turn: over the last turn the contour error is r·| |H(e^{jωT})| − 1 |, the single-axis radial_error metric
    (Koren eq 28, exact form), to a nanometre."""
    radius = 0.008
    turn = 2 * math.pi * radius
    turns = math.ceil(1.2 * feed / turn) + 1
    spec = machine(path={"type": "circle", "radius": radius, "feed": feed, "turns": turns})
    result = run(spec, builtin_path(spec.path))
    setting = nominal_setting(spec)
    loop = axis_loop(spec, "x", setting.values["x"], setting.period)
    expected = to_float(RadialError().evaluate(loop, CircleOptions(radius=radius,
                                                                   feed=feed)).expr)
    last = (result.arc_length > (turns - 1) * turn) & (result.arc_length < turns * turn - 1e-9)
    error = np.abs(np.hypot(result.actual[last, 0], result.actual[last, 1]) - radius)
    assert abs(expected) > 100 * NANOMETRE  # a radial error to compare, not a rounding
    assert np.max(np.abs(error - abs(expected))) < NANOMETRE
    # from rest at full feed the lag builds up from zero: the whole run's largest error
    # is the steady one's (the tool starts on the path, inside the circle it then cuts)
    assert result.metrics["max_contour_error"] >= abs(expected) - NANOMETRE


def closed_form(feed, angle, kx, ky):
    """ε = V sinθ cosθ (1/K_y − 1/K_x) (docs/design.md, "Multi-axis contouring")."""
    return feed * math.sin(angle) * math.cos(angle) * (1 / ky - 1 / kx)


@pytest.mark.parametrize("technique", ["sampled_data", "reference_pulse"])
@pytest.mark.parametrize("degrees", [15, 30, 45, 60, 80])
def test_mismatched_axes_on_a_line_follow_the_closed_form(technique, degrees):
    """K_x = 20, K_y = 30 1/s on a 0.2 m line at 0.1 m/s: on the middle of the line,
    after the transient, the contour error is |V sinθ cosθ (1/K_y − 1/K_x)| (to 1 nm)."""
    angle = math.radians(degrees)
    spec = machine(technique, gains=(20.0, 30.0),
                   path={"type": "line", "length": 0.2, "angle": angle, "feed": 0.1})
    result = run(spec, builtin_path(spec.path))
    steady = (result.time > 1.0) & (result.time < 1.5)  # 1 s = 50 τ after the start
    error = _distance(result)[steady]
    expected = abs(closed_form(0.1, angle, 20.0, 30.0))
    assert expected > 1e-4
    assert np.max(np.abs(error - expected)) < NANOMETRE


def test_block_starts_by_blocks_are_the_state_recursion():
    """20 000 samples in blocks of 8: the 2 500 block-start states are themselves
    simulated in blocks (twice nested) instead of a loop; still the per-sample recursion
    to rounding (1e-12 of the output's size). A lightly damped 3-state system, so that an
    error in the block-level recursion would show across many blocks."""
    rng = np.random.default_rng(11)
    a = np.array([[0.999, 0.02, 0.0], [-0.02, 0.999, 0.01], [0.0, 0.0, 0.9]])
    g, c, d = rng.normal(size=(3, 2)), rng.normal(size=3), rng.normal(size=2)
    u = rng.normal(size=(20_000, 2))
    x0 = rng.normal(size=3)
    y = simulate_lti(a, g, c, d, u, x0=x0, block=8)
    x, expected = x0.copy(), np.empty(len(u))
    for k in range(len(u)):
        expected[k] = c @ x + d @ u[k]
        x = a @ x + g @ u[k]
    assert np.max(np.abs(y - expected)) <= 1e-12 * np.max(np.abs(expected))


def _distance(result):
    return np.asarray(result.path.distance(result.actual))


def test_cross_coupling_reduces_the_mismatched_line_error():
    """The same line at 30°: Koren's P cross-coupled controller (K_c = 5) divides the
    steady contour error by 1 + K_c (docs/design.md: the correction K_c ε n moves the
    tool by K_c ε across the line once settled, so ε = ε₀ − K_c ε), and a PI (T_i = 0.05 s)
    removes it, a type-1 loop on ε; to 1 nm. The whole program's largest error falls too."""
    path = {"type": "line", "length": 0.2, "angle": math.radians(30), "feed": 0.1}
    plain = run(*_with(path, None))
    p_only = run(*_with(path, {"gain": 5.0}))
    pi = run(*_with(path, {"gain": 5.0, "integral_time": 0.05}))
    steady = (plain.time > 1.0) & (plain.time < 1.5)
    e0, e1, e2 = (_distance(r)[steady] for r in (plain, p_only, pi))
    expected = abs(closed_form(0.1, math.radians(30), 20.0, 30.0))
    assert np.max(np.abs(e0 - expected)) < NANOMETRE
    assert np.max(np.abs(e1 - expected / 6)) < NANOMETRE
    assert np.max(e2) < NANOMETRE
    assert pi.metrics["max_contour_error"] < plain.metrics["max_contour_error"]


def _lines_and_arcs() -> Path:
    """Three axes: a 3-D line, a 90° corner, a tangent arc of 5 mm left and one of 3 mm
    right, tangent (their lag, 2.5 mm at 50 mm/s on K_x = 20 1/s, comparable with the radius, so
    the estimate's arc term κ(tᵀE)²/2 is hundreds of µm), a line back, at 50 mm/s."""
    feed = 0.05
    p = [np.array(v, dtype=float) for v in ((0, 0, 0), (0.02, 0.005, 0.002),
                                            (0.02, 0.025, 0.002))]
    a_end = np.array([0.015, 0.030, 0.002])  # quarter circle about (0.015, 0.025), left
    segs = (Line(p[0], p[1], feed), Line(p[1], p[2], feed),
            Arc(p[2], a_end, np.array([0.015, 0.025, 0.002]), ccw=True, feed=feed),
            Arc(a_end, np.array([0.012, 0.033, 0.002]), np.array([0.015, 0.033, 0.002]),
                ccw=False, feed=feed),
            Line(np.array([0.012, 0.033, 0.002]), np.array([0.0, 0.033, 0.0]), feed))
    return Path(segs)


def _three_axes(gains=(20.0, 30.0, 25.0)):
    axes = {name: {"plant": {"type": "software_servo", "technique": technique,
                             "time_constant": tau},
                   "tunables": {"position_gain": {"value": k}}}
            for name, k, tau, technique in zip("xyz", gains, (0.02, 0.025, 0.03),
                                               ("sampled_data", "reference_pulse",
                                                "sampled_data"))}
    return parse_machine({"name": "ccc", "axes": axes, "sampling_period": {"value": 1e-3},
                          "interpolator": {"max_acceleration": 2.0}})


def _coupled_inputs():
    spec = _three_axes()
    path = _lines_and_arcs()
    result = run(spec, path, detail=False)
    tangent, curvature = path_direction(SegmentTable.of(path), result.arc_length,
                                        result.segment)
    return axis_models(spec, nominal_setting(spec)), result.commanded, tangent, curvature


@pytest.mark.parametrize("ccc", [CrossCoupling(5.0), CrossCoupling(5.0, 0.05),
                                 CrossCoupling(2.0, 0.01)])
def test_vectorised_cross_coupling_is_the_per_sample_loop(ccc):
    """Koren's cross-coupled controller on three mismatched axes (one continuous), over
    lines, a corner and arcs whose estimate's quadratic term is hundreds of µm: the
    vectorised simulation (blocked affine recursion, Newton passes for the arc term)
    equals the coupled loop stepped sample by sample, to a nanometre (1/5000 of Koren's
    5 µm BLU; the Newton passes stop at 1e-10 m, the blocked recursion is the same
    recursion reassociated). The coupling must matter: the correction moves the tool by
    far more than the tolerance."""
    models, reference, tangent, curvature = _coupled_inputs()
    stepped = simulate_coupled_stepped(models, reference, tangent, curvature, ccc)
    fast = simulate_coupled(models, reference, tangent, curvature, ccc)
    plain = machine_simulate.simulate_independent(models, reference)
    assert np.max(np.abs(stepped - plain)) > 1e-5
    assert np.max(np.abs(fast - stepped)) < NANOMETRE
    assert np.array_equal(fast[:, 2], plain[:, 2])  # z is not coupled


def test_cross_coupling_falls_back_to_the_per_sample_loop(monkeypatch):
    """With a single Newton pass allowed the arcs' quadratic term cannot converge: the
    answer is then the per-sample loop's, not the unconverged pass."""
    monkeypatch.setattr(machine_simulate, "NEWTON_STEPS", 1)
    models, reference, tangent, curvature = _coupled_inputs()
    ccc = CrossCoupling(5.0, 0.05)
    stepped = simulate_coupled_stepped(models, reference, tangent, curvature, ccc)
    assert np.array_equal(simulate_coupled(models, reference, tangent, curvature, ccc),
                          stepped)


def _with(path, ccc):
    spec = machine(gains=(20.0, 30.0), path=path, cross_coupling=ccc)
    return spec, builtin_path(spec.path)
