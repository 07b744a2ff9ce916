"""The closed-loop pole metrics (decay_rate, pole_damping) and the sensitivity peak M_s:
their polynomial tests, their values against closed forms, and their NLP rows.

Closed forms: Koren's reference-pulse loop K/(s(1 + sτ)) closes to s² + s/τ + K/τ, so
its poles are −1/(2τ) ± √(1/(4τ²) − K/τ): σ_min = 1/(2τ) and ζ = 1/(2√(Kτ)) when
underdamped (Kτ > 1/4), σ_min = (1 − √(1 − 4Kτ))/(2τ) and ζ_min = 1 when not.
"""

from __future__ import annotations

import functools
import math

import casadi as ca
import numpy as np
import pytest

from expression_values import as_numbers
from feedtune.expr import PoleRegion, Supremum
from feedtune.loops import linalg
from feedtune.loops.loop import ContinuousLoop, Drive, IntegratorLag, SampledLoop
from feedtune.objectives import METRICS
from feedtune.objectives.poles.pole_region import (decay_conditions, decay_factor_conditions,
                                                   damping_conditions, damping_factor_conditions,
                                                   factor_start, paired_roots, product,
                                                   rotated_product, routh_column, split_factors)
from feedtune.validate import poles as validator_poles

TAU = 0.02  # Koren's design example [s]


def reference_pulse(gain: float, tau: float = TAU) -> ContinuousLoop:
    """Koren's continuous loop K/(s(1 + sτ)) as the software_servo plant builds it."""
    a = ca.DM([[0, 1], [-gain / tau, -1 / tau]])
    b = ca.DM([[0], [gain / tau]])
    return ContinuousLoop(a, b, ca.DM([[1, 0]]), gain, Drive(time_constant=tau))


def sampled(gain: float, period: float, delay: int = 0) -> SampledLoop:
    return SampledLoop(IntegratorLag(TAU), ca.MX(gain), ca.MX(period), delay)


def value(name: str, loop) -> float:
    result = METRICS[name]().evaluate(loop, None)
    return float(ca.evalf(getattr(result, "exact", result)))


def conditions_hold(conditions, level: float) -> bool:
    return all(float(ca.evalf(ca.MX(c))) > 0 for c in conditions(ca.MX(level)))


# -- polynomial helpers ------------------------------------------------------------------------

def test_shifted_is_the_taylor_shift():
    rng = np.random.default_rng(3)
    p = rng.normal(size=6)
    for shift in (-2.5, 0.3, 1.7):
        q = np.array([float(c) for c in linalg.taylor_shift([ca.DM(c) for c in p], shift)])
        x = rng.normal(size=5)
        assert np.allclose(np.polyval(q, x), np.polyval(p, x + shift), rtol=1e-12, atol=1e-12)


def test_rotated_product_has_the_roots_turned_both_ways():
    roots = np.array([-1 + 2j, -1 - 2j, -0.5, -3.0])
    p = np.real(np.poly(roots))
    angle = 0.4
    q = np.array([float(ca.evalf(ca.MX(c))) for c in rotated_product([ca.DM(c) for c in p], angle)])
    expected = np.concatenate([roots * np.exp(1j * angle), roots * np.exp(-1j * angle)])
    found = np.roots(q / q[0])
    for r in expected:  # each expected root found, to the rounding of np.roots on degree 8
        assert np.min(np.abs(found - r)) < 1e-8 * max(1, abs(r))


def test_routh_column_decides_stability_as_the_roots_do():
    """Random real polynomials of degree 2–12 with real roots and pairs spread over two
    decades, half of them unstable: every entry positive exactly when every root has
    Re < 0, and the same verdict as the Hurwitz minors (feedtune.loops.linalg)."""
    rng = np.random.default_rng(11)
    for _ in range(300):
        n = int(rng.integers(2, 13))
        roots = []
        while len(roots) < n:
            size = 10 ** rng.uniform(-1, 1)
            if n - len(roots) >= 2 and rng.random() < 0.6:
                angle = rng.uniform(0, math.pi)
                roots += [size * np.exp(1j * angle), size * np.exp(-1j * angle)]
            else:
                roots.append(size * rng.choice([-1.0, 1.0]))
        roots = np.array(roots)
        if rng.random() < 0.5:  # stable half: mirror every root into the left half plane
            roots = -np.abs(roots.real) + 1j * roots.imag
        if np.min(np.abs(roots.real)) < 1e-3 * np.max(np.abs(roots)):
            continue  # too close to the boundary for a floating-point verdict
        column, minors = _routh_and_hurwitz(n)(np.real(np.poly(roots)))
        routh = bool(np.all(np.array(column) > 0))
        hurwitz = bool(np.all(np.array(minors) > 0))
        assert routh == hurwitz == bool(np.all(roots.real < 0)), roots


@functools.lru_cache(maxsize=None)
def _routh_and_hurwitz(degree: int) -> ca.Function:
    """coefficients (highest power first) ↦ (Routh column, Hurwitz conditions), the two
    tests written out on symbols once per degree, as the NLP builds them: the same double
    operations on each polynomial as building them on ``DM`` numbers, without redoing the
    O(n⁴) minors in Python for every one of the 300 (11 s of CPU at load 15, issue 15)."""
    a = ca.SX.sym("a", degree + 1)
    coefficients = [a[i] for i in range(degree + 1)]
    return ca.Function("routh_hurwitz", [a], [ca.vertcat(*routh_column(coefficients)),
                                              ca.vertcat(*linalg.hurwitz_conditions(coefficients))])


# -- the factor form: p = ∏(s² + a s + b)·(s + c) -------------------------------------------------

def random_roots(rng, n: int, stable: bool = True) -> np.ndarray:
    """n roots of a real polynomial: pairs and reals of sizes 0.1…10, left half plane."""
    roots = []
    while len(roots) < n:
        size = 10 ** rng.uniform(-1, 1)
        if n - len(roots) >= 2 and rng.random() < 0.6:
            angle = rng.uniform(0.05, math.pi / 2 - 0.05)
            roots += [-size * np.exp(1j * angle), -size * np.exp(-1j * angle)]
        else:
            roots.append(-size if stable else size * rng.choice([-1.0, 1.0]))
    return np.array(roots)


def numbers(values) -> np.ndarray:
    """Scalar expressions as floats, in one evaluation of their column (as_numbers)."""
    return as_numbers(values)


def test_factor_start_rebuilds_the_polynomial():
    """300 random real polynomials of degree 1–12: the factors of their numpy roots
    multiply back to the polynomial, each coefficient to 1e-12 of its natural size (the
    product taken with |a|, |b|, |c|: its sum of |terms|), with ⌊n/2⌋ quadratic factors and
    a linear one for odd n; each quadratic holds a conjugate pair or two real roots."""
    rng = np.random.default_rng(5)
    for _ in range(300):
        n = int(rng.integers(1, 13))
        roots = random_roots(rng, n, stable=rng.random() < 0.5)
        x, size = factor_start(roots)
        assert x.size == n and size.size == n and np.all(size > 0)
        got, magnitude = numbers(product(list(x), n)), numbers(product(list(x), n, abs))
        assert np.all(np.abs(got - np.real(np.poly(roots))) <= 1e-12 * magnitude), roots
        for a, b in zip(x[0:2 * (n // 2):2], x[1:2 * (n // 2):2]):
            pair = np.roots([1, a, b])
            assert np.min(np.abs(roots[:, None] - pair[None, :]), axis=0).max() <= 1e-9 * 10


def test_an_odd_count_of_real_roots_leaves_the_lone_one_out():
    """−1, −1.1 and −50: the pairs' summed gap is least with −50 alone."""
    pairs, single = paired_roots(np.array([-50.0, -1.1, -1.0]))
    assert single == -50.0 and len(pairs) == 1
    assert sorted(r.real for r in pairs[0]) == [-1.1, -1.0]


def holds(rows) -> bool:
    return bool(np.all(numbers(rows) > 0))


def test_factor_conditions_switch_at_the_smallest_damping_and_decay():
    """200 random stable polynomials of degree 1–10: the damping rows (a > 0, b > 0,
    a² ≥ 4ζ²b, c > 0) hold at 0.999999·ζ_min and fail at 1.000001·ζ_min; the decay rows
    (a > 2σ, σ² − aσ + b > 0, c > σ, with ω0 = 1) the same at σ_min. 1e-6 relative: both
    are simple roots in the level of a row that changes sign there."""
    rng = np.random.default_rng(7)
    for _ in range(200):
        n = int(rng.integers(1, 11))
        roots = random_roots(rng, n)
        quadratic, linear = split_factors(list(factor_start(roots)[0]), n)
        zeta = float(np.min(-roots.real / np.abs(roots)))
        sigma = float(np.min(-roots.real))
        if zeta < 1 - 1e-9:
            assert holds(damping_factor_conditions(zeta * (1 - 1e-6), quadratic, linear, 1, None))
            assert not holds(damping_factor_conditions(zeta * (1 + 1e-6), quadratic, linear,
                                                       1, None))
        assert holds(decay_factor_conditions(sigma * (1 - 1e-6), quadratic, linear, 1.0, None))
        assert not holds(decay_factor_conditions(sigma * (1 + 1e-6), quadratic, linear, 1.0,
                                                 None))


def test_sampled_decay_rows_switch_at_the_radius():
    """Jury's rows on z-roots inside the unit disc (reals of either sign, pairs, a root at
    0 as a computation delay gives): they hold at r = 1.000001·max|z| and fail at
    0.999999·max|z|, r = e^{−σT} (T = 1 ms)."""
    rng = np.random.default_rng(9)
    period = 1e-3
    for _ in range(200):
        n = int(rng.integers(1, 9))
        roots = []
        while len(roots) < n:
            size = rng.uniform(0.05, 0.95)
            if n - len(roots) >= 2 and rng.random() < 0.6:
                angle = rng.uniform(0.05, math.pi - 0.05)
                roots += [size * np.exp(1j * angle), size * np.exp(-1j * angle)]
            else:
                roots.append(size * rng.choice([-1.0, 1.0]))
        roots = np.array(roots)
        if n > 1 and rng.random() < 0.3:
            roots[np.argmin(np.abs(roots.imag))] = 0.0  # a real root (or a pair's half) to 0
            roots = np.roots(np.real(np.poly(roots)))
        quadratic, linear = split_factors(list(factor_start(roots)[0]), n)
        radius = float(np.max(np.abs(roots)))
        for factor, verdict in ((1 + 1e-6, True), (1 - 1e-6, False)):
            sigma = -math.log(radius * factor) / period
            assert holds(decay_factor_conditions(sigma, quadratic, linear, 1.0, period)) == verdict


@pytest.mark.parametrize("loop", [reference_pulse(5.0), reference_pulse(100.0),
                                  sampled(40.0, 0.005), sampled(20.0, 0.01, 2)],
                         ids=["overdamped", "underdamped", "sampled", "sampled-delay-2"])
def test_a_loops_factors_match_its_polynomial_and_switch_at_its_decay_rate(loop):
    """The region's Factors on a loop of numbers: started at its poles, the matching
    residuals vanish to 1e-12 of each row's magnitude, and the factor rows switch at the
    metric's value (1e-6 relative, as the Routh test above)."""
    region = METRICS["decay_rate"]().evaluate(loop, None)
    inputs = np.array(ca.evalf(region.inputs), dtype=float)
    x, _ = region.factors.start(inputs)
    assert x.size == region.factors.size
    x = [ca.MX(v) for v in x]
    for residual, magnitude in region.factors.matching(x):
        assert abs(numbers([residual])[0]) <= 1e-12 * numbers([magnitude])[0]
    sigma = value("decay_rate", loop)
    assert holds(region.factors.conditions(ca.MX(sigma * (1 - 1e-6)), x))
    assert not holds(region.factors.conditions(ca.MX(sigma * (1 + 1e-6)), x))


# -- values against closed forms ---------------------------------------------------------------

@pytest.mark.parametrize("gain", [5.0, 12.5 * 0.9, 25.0, 200.0])
def test_continuous_values_are_the_closed_forms(gain):
    loop = reference_pulse(gain)
    k_tau = gain * TAU
    if k_tau > 0.25:
        decay, zeta = 1 / (2 * TAU), 1 / (2 * math.sqrt(k_tau))
    else:
        decay, zeta = (1 - math.sqrt(1 - 4 * k_tau)) / (2 * TAU), 1.0
    # eigenvalues of a 2×2 matrix: rounding ~1e-15 relative to |p| ≈ 50 rad/s
    assert value("decay_rate", loop) == pytest.approx(decay, rel=1e-12)
    assert value("pole_damping", loop) == pytest.approx(zeta, rel=1e-12)


def test_sampled_values_map_the_z_poles_by_ln_z_over_t():
    """Koren's sampled loop: its pole pair z as numpy finds it, s = ln(z)/T; with a
    computation delay of one sample the third pole counts too."""
    for delay in (0, 1):
        loop = sampled(40.0, 0.005, delay)
        z = np.linalg.eigvals(np.array(ca.evalf(loop.state_matrix)))
        s = np.log(z.astype(complex)) / 0.005
        assert value("decay_rate", loop) == pytest.approx(np.min(-s.real), rel=1e-12)
        assert value("pole_damping", loop) == pytest.approx(
            np.min(-s.real / np.abs(s)), rel=1e-12)
    # Koren eq 19 on the second-order loop: the pair's ζ is damping_ratio's
    loop = sampled(40.0, 0.005)
    assert value("pole_damping", loop) == pytest.approx(value("damping_ratio", loop), rel=1e-9)


def test_a_negative_real_z_pole_rings_at_nyquist():
    """z = −a maps to s = (ln a ± jπ)/T (MATLAB's damp); the validator agrees."""
    z = np.array([-0.5, 0.9])
    s = validator_poles.s_plane(z, True, 0.01)
    expected = -math.log(0.5) / math.hypot(math.log(0.5), math.pi)
    assert validator_poles.pole_damping(s) == pytest.approx(expected, rel=1e-14)
    assert validator_poles.decay_rate(s)[0] == pytest.approx(-math.log(0.9) / 0.01, rel=1e-14)


def test_a_pole_at_the_origin_of_the_z_plane_limits_nothing():
    s = validator_poles.s_plane(np.array([0.0, 0.5]), True, 0.01)
    assert s.size == 1
    assert validator_poles.decay_rate(s)[0] == pytest.approx(-math.log(0.5) / 0.01)


# -- the NLP's tests hold exactly where the value says ---------------------------------------

@pytest.mark.parametrize("loop", [reference_pulse(5.0), reference_pulse(100.0),
                                  sampled(40.0, 0.005), sampled(20.0, 0.01, 2)],
                         ids=["overdamped", "underdamped", "sampled", "sampled-delay-2"])
def test_decay_conditions_switch_at_the_decay_rate(loop):
    sigma = value("decay_rate", loop)
    conditions = decay_conditions(loop)
    # 1e-6 relative: the conditions are polynomials in σ with a simple root at σ_min
    assert conditions_hold(conditions, sigma * (1 - 1e-6))
    assert not conditions_hold(conditions, sigma * (1 + 1e-6))
    assert conditions_hold(conditions, 0.0)  # stable: σ = 0 is the stability test


@pytest.mark.parametrize("gain", [30.0, 100.0, 1000.0])
def test_damping_conditions_switch_at_the_smallest_damping(gain):
    loop = reference_pulse(gain)
    zeta = value("pole_damping", loop)
    conditions = damping_conditions(loop)
    assert conditions_hold(conditions, zeta * (1 - 1e-6))
    assert not conditions_hold(conditions, zeta * (1 + 1e-6))


def test_damping_conditions_on_a_higher_order_loop():
    """An eighth-order loop with a light pair among fast real poles and a well damped pair
    (Bhatia's kind of spectrum): the test switches at the light pair's ζ."""
    roots = np.array([-5712.6, -2000.5, -74.3, -60.4 + 50.3j, -60.4 - 50.3j,
                      -23.2 + 172.0j, -23.2 - 172.0j, -7.68])
    loop = ContinuousLoop(ca.DM(linalg_companion(roots)), ca.DM.zeros(8, 1),
                          ca.DM.zeros(1, 8), 1.0)
    zeta = float(np.min(-roots.real / np.abs(roots)))
    assert value("pole_damping", loop) == pytest.approx(zeta, rel=1e-9)
    conditions = damping_conditions(loop)
    assert conditions_hold(conditions, zeta * (1 - 1e-6))
    assert not conditions_hold(conditions, zeta * (1 + 1e-6))
    sigma = value("decay_rate", loop)
    assert sigma == pytest.approx(7.68, rel=1e-9)
    assert conditions_hold(decay_conditions(loop), sigma * (1 - 1e-6))
    assert not conditions_hold(decay_conditions(loop), sigma * (1 + 1e-6))


def linalg_companion(roots) -> np.ndarray:
    p = np.real(np.poly(roots))
    return np.array(ca.evalf(linalg.companion_matrix([ca.DM(c) for c in p])))


def test_damping_has_no_polynomial_test_on_a_sampled_loop():
    """Reported only there: not optimisable, and a loop of symbols is refused (TypeError)
    rather than given a value the NLP would trust."""
    metric = METRICS["pole_damping"]()
    assert not metric.optimisable(sampled(40.0, 0.005))
    assert metric.optimisable(reference_pulse(40.0))
    k = ca.MX.sym("k")
    with pytest.raises(TypeError):
        metric.evaluate(SampledLoop(IntegratorLag(TAU), k, ca.MX(0.005)), None)


def test_pole_metrics_are_regions_and_sensitivity_peak_a_supremum():
    loop = reference_pulse(40.0)
    assert isinstance(METRICS["decay_rate"]().evaluate(loop, None), PoleRegion)
    assert METRICS["decay_rate"].direction == METRICS["pole_damping"].direction == "min"
    assert METRICS["sensitivity_peak"].direction is None
    assert not METRICS["sensitivity_peak"]().supports(loop)  # no open loop L(jω) here


def test_sensitivity_peak_of_bhatias_loop_is_max_of_one_over_one_plus_l():
    """M_s on Bhatia's hydraulic loop (the example's initial design) against |1/(1 + L)|
    from the loop's own open loop on a dense grid polished by golden section: two
    evaluations of the same L, so agreement to 1e-9 (the grid's refinement, not rounding,
    sets it)."""
    from scipy.optimize import minimize_scalar

    from feedtune.plants import plant_for
    from feedtune.schema.spec import parse_spec
    import json
    from pathlib import Path

    spec = parse_spec(json.loads((Path(__file__).resolve().parents[2] / "examples"
                                  / "bhatia-1971-hydraulic.json").read_text()))
    plant = plant_for(spec.plant)
    box = {n: (t.min, t.max) for n, t in plant.tunables().items()}
    values = {n: ca.MX(spec.tunables[n].initial) for n in plant.tunables()}
    loop = plant.loop(values, box)
    result = METRICS["sensitivity_peak"]().evaluate(loop, None)
    assert isinstance(result, Supremum)

    omega = ca.MX.sym("omega")
    response = ca.Function("L", [omega], [ca.vertcat(*loop.open_loop_response(omega))])

    def size(w):
        re, im = np.array(response(w)).ravel()
        return float(1 / np.hypot(1 + re, im))

    grid = np.geomspace(1e-1, 1e5, 20_001)
    re, im = np.array(response.map(grid.size)(grid[None, :]))  # the grid in one call
    sizes = 1 / np.hypot(1 + re, im)
    k = int(np.argmax(sizes))
    polished = minimize_scalar(lambda u: -size(math.exp(u)), method="bounded",
                               bounds=(math.log(grid[k - 1]), math.log(grid[k + 1])),
                               options={"xatol": 1e-12})
    assert float(ca.evalf(result.exact)) == pytest.approx(-polished.fun, rel=1e-9)


# -- what the tuner and the spec refuse ------------------------------------------------------

def test_the_tuner_refuses_an_upper_bound_and_minimisation():
    """A pole region can only be held from below: "some pole is slow" has no smooth rows."""
    from feedtune.tuner.builder import NlpBuilder
    from feedtune.tuner.terms import add_bound, add_term
    from feedtune.tuner.types import Bound

    region = METRICS["decay_rate"]().evaluate(reference_pulse(40.0), None)
    builder = NlpBuilder([])
    with pytest.raises(ValueError, match="bounded from below"):
        add_bound(builder, 0, region, None, Bound("decay_rate", None, 1.0, 2.0), 1.0, [])
    with pytest.raises(ValueError, match="maximised"):
        add_term(builder, 0, region, None, ca.MX(1), 1.0, 1.0, [])


SERVO = {"name": "t", "plant": {"type": "software_servo", "technique": "sampled_data",
                                "time_constant": 0.02},
         "tunables": {"position_gain": {"min": 1, "max": 200}},
         "objective": [{"metric": "iae"}]}


@pytest.mark.parametrize("change, pointer, words", [
    ({"objective": [{"metric": "decay_rate", "goal": "minimize"}]}, "/objective/0/goal",
     "'maximize'"),
    ({"constraints": [{"metric": "decay_rate", "min": 1, "max": 30}]}, "/constraints/0/max",
     "can only be bounded from below"),
    ({"constraints": [{"metric": "pole_damping", "min": 0.5}]}, "/constraints/0/metric",
     "reported only"),
    # a loop without an open loop (Koren's reference-pulse loop has one since issue 16)
    ({"plant": {"type": "pulse_generator", "pulse_equivalent": 0.003, "position_unit": "rad",
                "motor_characteristic": [[0, 140000], [140000, 140000]]},
      "tunables": {"error_limit": {"min": 0.05, "max": 5}},
      "objective": [{"metric": "pulse_settling_time"}],
      "constraints": [{"metric": "sensitivity_peak", "max": 2}]}, "/constraints/0/metric",
     "not defined for this plant configuration, pulse_generator"),
])
def test_the_spec_refuses_what_the_tuner_cannot_hold(change, pointer, words):
    from feedtune.schema.spec import SpecError, parse_spec

    with pytest.raises(SpecError) as info:
        parse_spec({**SERVO, **change})
    errors = dict(info.value.errors)
    assert list(errors) == [pointer] and words in errors[pointer]


def test_the_spec_takes_a_maximised_region_by_default():
    from feedtune.schema.spec import parse_spec

    spec = parse_spec({**SERVO, "objective": [{"metric": "decay_rate"}],
                       "constraints": [{"metric": "decay_rate", "min": 5}]})
    assert spec.objective[0].goal == "maximize"


# -- the validator's check can fail ----------------------------------------------------------

class _Poles:
    """A validator model reduced to what feedtune.validate.poles reads."""

    def __init__(self, poles, sampled=False, period=None):
        self._poles, self.sampled, self.period = np.asarray(poles), sampled, period

    def poles(self):
        return self._poles

    def context(self):
        from feedtune.validate.tolerances import Context

        return Context(time=1.0)


def test_validator_entries_catch_a_wrong_value():
    """Poles −2 ± 4j, −10: σ_min = 2 1/s (judged on |p| = √20), ζ_min = 2/√20. A reported
    value off by 1e-3 is caught; one off by rounding (1e-13) is not."""
    model = _Poles([-2 + 4j, -2 - 4j, -10])
    zeta = 2 / math.sqrt(20)

    def entries(decay, damping):
        result = {"metrics": {
            "decay_rate": {"metric": "decay_rate", "options": {}, "value": decay, "unit": "1/s"},
            "pole_damping": {"metric": "pole_damping", "options": {}, "value": damping,
                             "unit": "1"}}}
        return {e["metric"]: e for e in validator_poles.pole_entries(model, result)}

    good = entries(2.0 + 1e-13, zeta + 1e-13)
    assert good["decay_rate"]["ok"] and good["pole_damping"]["ok"]
    assert good["decay_rate"]["tolerance"] == pytest.approx(1e-6 * math.sqrt(20))
    bad = entries(2.001, zeta + 1e-3)
    assert not bad["decay_rate"]["ok"] and not bad["pole_damping"]["ok"]
