"""Contract of every registered metric (feedtune.objectives.METRICS) on every plant configuration.

Cases are generated from the registries (contract_cases.py): a metric is evaluated on every
configuration and option set it says it ``supports``.
"""

from __future__ import annotations

import functools
import inspect
import math

import casadi as ca
import numpy as np
import pytest

from contract_cases import (CONFIGS, OPTION_SAMPLES, as_float, exact_expr, exact_metric_cases,
                            log_point, metric_cases,
                            narrow_box, nominal, nominal_loop, numeric_loop, numeric_metric,
                            option_variants, symbolic_loop)
from feedtune.expr import Crossing, PoleRegion, Supremum, Unbounded
from feedtune.loops.loop import HorizonError
from feedtune.objectives import METRICS
from feedtune.objectives.base import Metric
from feedtune.schema.model import SpecModel

CASES = metric_cases()
CASE_IDS = [f"{name}-{config.id}-{options.model_dump()}" for config, name, options in CASES]


def _expr(value):
    return exact_expr(value)


@functools.lru_cache(maxsize=None)
def _symbolic_loop(config):
    """(z, loop): the loop of log-tunable symbols in the factor-2 box around the nominal
    point, one per configuration and shared by its metrics' cases, as the tuner builds one
    loop for all of a spec's metrics: what they share is located once on it (the gain
    crossover of the crossover frequency, phase and gain margins). Metrics only read it."""
    return symbolic_loop(config, narrow_box(config, nominal(config)))


@functools.lru_cache(maxsize=None)
def _symbolic_value(config, name, options):
    """The metric's value on :func:`_symbolic_loop`, evaluated once for the two tests that
    read it (finite with a gradient; reformulated: only REFORMULATED's cases are kept), as
    the tuner evaluates each metric of a spec once. Read it only: each test builds its own
    Functions from it."""
    return METRICS[name]().evaluate(_symbolic_loop(config)[1], options)


def _default_box_loop(config):
    """The loop of numbers at the nominal point with the plant's default bounds, one per
    configuration and shared by its metrics' cases (as :func:`_symbolic_loop`) and the
    plant contract's tests at that point (``contract_cases.nominal_loop``)."""
    return nominal_loop(config)


# -- declarations ------------------------------------------------------------------------------

@pytest.mark.parametrize("key", sorted(METRICS))
def test_metric_declares_name_unit_description(key):
    cls = METRICS[key]
    assert issubclass(cls, Metric)
    assert cls.name == key
    for attribute in ("unit", "description"):
        value = getattr(cls, attribute)
        assert isinstance(value, str) and value.strip(), f"{key}.{attribute}"
    assert inspect.getdoc(cls) and inspect.getdoc(cls) != inspect.getdoc(Metric), f"{key} has no docstring"
    assert inspect.getmodule(cls).__doc__, f"module of {key} has no docstring"


@pytest.mark.parametrize("key", sorted(METRICS))
def test_metric_options_are_documented(key):
    options = METRICS[key].Options
    assert issubclass(options, SpecModel)  # frozen, extra="forbid", no NaN
    assert inspect.getdoc(options)
    for name, info in options.model_fields.items():
        assert info.description and info.description.strip(), f"{key} option {name} has no description"


@pytest.mark.parametrize("key", sorted(METRICS))
def test_metric_options_can_be_sampled(key):
    """Options without defaults need a sample value in contract_cases.OPTION_SAMPLES."""
    options = METRICS[key].Options
    missing = [n for n, info in options.model_fields.items()
               if info.is_required() and n not in OPTION_SAMPLES]
    assert not missing, f"add sample values for {missing} to OPTION_SAMPLES"
    assert option_variants(METRICS[key])


@pytest.mark.parametrize("key", sorted(METRICS))
def test_every_metric_is_supported_by_some_configuration(key):
    """Otherwise the evaluation contract below would hold vacuously for it."""
    assert any(name == key for _, name, _ in CASES + exact_metric_cases()), \
        f"no plant configuration supports {key}"


# -- evaluation ----------------------------------------------------------------------------------

@pytest.mark.parametrize("config, name, options", CASES, ids=CASE_IDS)
def test_metric_is_finite_with_finite_gradient(config, name, options):
    """Numeric evaluation is finite; symbolic evaluation agrees and has a finite gradient.

    At the nominal point, in a factor-2 box around it (a spec that narrows the search; the
    default box may be too wide for a step-response horizon, see the test below). A metric
    that declares ``infinite_when`` may be +∞ (an :class:`~feedtune.expr.Unbounded` whose
    quantity does not exist here); the NLP then reads its finite stand-in, which must be
    finite with a finite gradient.
    """
    metric = METRICS[name]()
    point = nominal(config)

    numeric_value, numeric_loop = numeric_metric(config, name, options)
    _check_declared_kind(metric, numeric_value)
    numeric = as_float(numeric_value)
    assert math.isfinite(numeric) or (metric.infinite_when and numeric == math.inf)

    z, loop = _symbolic_loop(config)
    optimisable = metric.optimisable(loop, options)
    assert isinstance(optimisable, bool) and metric.optimisable(numeric_loop, options) == optimisable
    if not optimisable:
        # reported only (evaluated numerically on the tuned design): a loop of symbols is
        # refused, never turned into a wrong expression the NLP would trust
        with pytest.raises(TypeError):
            metric.evaluate(loop, options)
        return
    # a value the reformulated test reads again is kept (_symbolic_value); the others are not
    value = (_symbolic_value(config, name, options) if (config, name, options) in REFORMULATED
             else metric.evaluate(loop, options))
    _check_declared_kind(metric, value)
    if isinstance(value, PoleRegion):
        _check_pole_region(value, z, log_point(config, point), numeric)
        return
    if isinstance(value, Unbounded):  # the exact value agrees; the NLP reads the stand-in
        exact = ca.Function("exact", [z], [value.exact])(log_point(config, point))
        assert float(exact) == pytest.approx(numeric, rel=1e-6, abs=1e-14)
        value = value.finite
    expr = ca.MX(_expr(value))
    f = ca.Function("metric", [z], [expr, ca.jacobian(expr, z)])
    symbolic, gradient = f(log_point(config, point))
    symbolic, gradient = float(symbolic), np.array(gradient, dtype=float)
    assert math.isfinite(symbolic)
    assert np.all(np.isfinite(gradient)), gradient
    if math.isinf(numeric):
        return
    # same formulas, on exp(ln x) instead of x (one ulp); step responses summed to the horizon
    # + closed-form tail (symbolic) vs until settled (numeric). 1e-6 because min_radius
    # magnifies rounding in |H| by 2r/BLU ≈ 1e6 at these points (see tests/unit/test_metrics.py)
    assert symbolic == pytest.approx(numeric, rel=1e-6, abs=1e-14)


def _check_pole_region(value: PoleRegion, z, at, numeric: float) -> None:
    """A pole region's value is its numeric measure (never an expression the NLP reads):
    on the loop of symbols its ``measure`` at the point equals the loop of numbers' value,
    and its polynomial conditions, finite with finite gradients, hold just below that
    value and fail just above it (1e-6 relative: the conditions have a simple root there
    unless two poles tie)."""
    inputs = ca.Function("inputs", [z], [value.inputs])
    assert value.measure(np.array(inputs(at), dtype=float)) == pytest.approx(numeric, rel=1e-9)
    level = ca.MX.sym("level")
    conditions = ca.vertcat(*value.conditions(level))
    f = ca.Function("conditions", [z, level], [conditions, ca.jacobian(conditions, z)])
    for factor, hold in ((1 - 1e-6, True), (1 + 1e-6, False)):
        if numeric * factor > value.upper:
            continue  # ζ_min = 1 (real poles only): nothing lies above
        rows, gradient = (np.array(v, dtype=float) for v in f(at, numeric * factor))
        assert np.all(np.isfinite(rows)) and np.all(np.isfinite(gradient))
        assert bool(np.all(rows > 0)) == hold, (factor, rows.ravel())


def _check_declared_kind(metric: Metric, value) -> None:
    """``value`` is of the kind the metric's class declares (``reformulated_as``): a
    Supremum or a Crossing exactly where it says so, which is how the cases of the
    reformulated test below are chosen without evaluating any metric."""
    declared = type(metric).reformulated_as
    assert declared in (None, Supremum, Crossing), declared
    if declared is None:
        assert not isinstance(value, (Supremum, Crossing)), \
            f"{metric.name} returns a {type(value).__name__}: declare reformulated_as"
    else:
        assert isinstance(value, declared), f"{metric.name}: {type(value).__name__}, declared {declared}"


def _reformulated(config, name, options) -> bool:
    """The metric's value is one the tuner reformulates (a supremum or crossing over ω).

    Decided at collection, in every test worker, from the class's declaration
    (``reformulated_as``, checked against every value by the finite test above): no metric
    is evaluated here (≈ 2.4 s of CPU a worker when each optimisable metric's value was)."""
    cls = METRICS[name]
    return cls.reformulated_as is not None and cls().optimisable(numeric_loop(config), options)


REFORMULATED = [case for case in CASES if _reformulated(*case)]


@pytest.mark.parametrize("config, name, options", REFORMULATED,
                         ids=[f"{n}-{c.id}-{o.model_dump()}" for c, n, o in REFORMULATED])
def test_reformulated_metric_is_consistent_with_its_exact_value(config, name, options):
    """What the tuner constrains instead of the exact value (a peak: fn(ω_k) ≤ t on the grid;
    a crossing: condition(b) = 0 and condition(b·x) ≥ 0 below it) holds at the exact value,
    is finite and has finite gradients. A supremum is at least every grid value and is
    taken where its ``argmax`` says; a crossing is the lowest: the condition is
    non-negative on the relative grid below it and at its refined minimum there, whose
    location (what the tuner's exchange step adds) lies below b.
    """
    point = nominal(config)
    z, _ = _symbolic_loop(config)
    value = _symbolic_value(config, name, options)
    omega = ca.MX.sym("omega")
    if isinstance(value, Supremum):
        fn = ca.Function("fn", [omega, z], [value.fn(omega)])
        pieces = fn.map(len(value.grid))(ca.DM(value.grid).T, z).T
        exact = value.exact
        # the peak's location: fn there is the peak (0 stands for ω → 0)
        at = ca.if_else(value.argmax > 0, value.fn(ca.fmax(value.argmax, 1e-300)), exact)
    else:
        b = value.exact
        fn = ca.Function("condition", [omega, z], [value.condition(omega)])
        below = fn.map(len(value.relative_grid))(b * ca.DM(value.relative_grid).T, z).T
        lowest, where = value.lowest_minimum(b, 0.0)
        pieces = ca.vertcat(value.condition(b), below, lowest)
        exact = b
        # the dip's location: below b, and the condition there is the minimum
        at = ca.vertcat(where / b, value.condition(where) - lowest)
    # finite gradients of every piece: one directional derivative with positive weights
    # (a NaN or ±inf in any row shows; the full Jacobian costs seconds per case)
    weights = ca.DM(np.random.default_rng(0).uniform(0.5, 1.0, pieces.shape[0]))
    f = ca.Function("pieces", [z], [exact, pieces, ca.gradient(ca.dot(weights, pieces), z), at])
    exact, pieces, gradient, at = (np.array(v, dtype=float) for v in f(log_point(config, point)))
    exact = float(exact.ravel()[0])
    pieces, at = pieces.ravel(), at.ravel()
    assert math.isfinite(exact) and np.all(np.isfinite(pieces)) and np.all(np.isfinite(gradient))
    if isinstance(value, Supremum):
        assert value.grid.ndim == 1 and len(value.grid) > 1 and np.all(np.diff(value.grid) > 0)
        assert pieces.max() <= exact * (1 + 1e-12)
        assert at[0] == pytest.approx(exact, rel=1e-12)
    else:
        assert 0 < at[0] <= 1 + 1e-12 and abs(at[1]) <= 1e-9  # as condition(b) below
        lo, hi = value.band
        assert lo < exact < hi, "no crossing in the band at the nominal point"
        assert np.all((value.relative_grid > 0) & (value.relative_grid < 1))
        # condition(b) = 0 to the rounding of the solved crossing; ≥ 0 below it
        scale = max(1.0, float(np.abs(pieces).max()))
        assert abs(pieces[0]) <= 1e-9 * scale
        assert pieces[1:].min() >= -1e-9 * scale


@pytest.mark.parametrize("config, name, options", CASES, ids=CASE_IDS)
def test_metric_on_the_default_box_is_finite_or_a_horizon_error(config, name, options):
    """With the plant's default bounds a metric either evaluates or says the horizon is too long."""
    metric = METRICS[name]()
    loop = _default_box_loop(config)
    try:
        value = as_float(metric.evaluate(loop, options))
    except HorizonError as error:
        assert "raise the minimum sampling period" in str(error)
        return
    assert math.isfinite(value) or (metric.infinite_when and value == math.inf)


@pytest.mark.parametrize("config", CONFIGS, ids=[c.id for c in CONFIGS])
def test_supports_accepts_every_option_variant(config):
    """supports() takes (loop, options) for every metric and returns a bool."""
    loop = config.plant.loop(nominal(config), narrow_box(config, nominal(config)))
    for cls in METRICS.values():
        for options in option_variants(cls):
            assert isinstance(cls().supports(loop, options), bool)
