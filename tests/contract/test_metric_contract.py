"""Contract of every registered metric (feedtune.objectives.METRICS) on every plant configuration.

Cases are generated from the registries (contract_cases.py): a metric is evaluated on every
configuration and option set it says it ``supports``.
"""

from __future__ import annotations

import inspect
import math

import casadi as ca
import numpy as np
import pytest

from contract_cases import (CONFIGS, OPTION_SAMPLES, as_float, log_point, metric_cases,
                            narrow_box, nominal, option_variants, symbolic_loop)
from feedtune.expr import Magnitude
from feedtune.loop import HorizonError
from feedtune.model import SpecModel
from feedtune.objectives import METRICS
from feedtune.objectives.base import Metric

CASES = metric_cases()
CASE_IDS = [f"{name}-{config.id}-{options.model_dump()}" for config, name, options in CASES]


def _expr(value):
    return value.expr if isinstance(value, Magnitude) else value


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
    assert any(name == key for _, name, _ in CASES), f"no plant configuration supports {key}"


# -- evaluation ----------------------------------------------------------------------------------

@pytest.mark.parametrize("config, name, options", CASES, ids=CASE_IDS)
def test_metric_is_finite_with_finite_gradient(config, name, options):
    """Numeric evaluation is finite; symbolic evaluation agrees and has a finite gradient.

    At the nominal point, in a factor-2 box around it (a spec that narrows the search; the
    default box may be too wide for a step-response horizon, see the test below).
    """
    metric = METRICS[name]()
    point = nominal(config)
    box = narrow_box(config, point)

    numeric = as_float(metric.evaluate(config.plant.loop(point, box), options))
    assert math.isfinite(numeric)

    z, loop = symbolic_loop(config, box)
    value = metric.evaluate(loop, options)
    expr = ca.MX(_expr(value))
    f = ca.Function("metric", [z], [expr, ca.jacobian(expr, z)])
    symbolic, gradient = f(log_point(config, point))
    symbolic, gradient = float(symbolic), np.array(gradient, dtype=float)
    assert math.isfinite(symbolic)
    assert np.all(np.isfinite(gradient)), gradient
    # same formulas, on exp(ln x) instead of x (one ulp); step responses summed to the horizon
    # + closed-form tail (symbolic) vs until settled (numeric). 1e-6 because min_radius
    # magnifies rounding in |H| by 2r/BLU ≈ 1e6 at these points (see tests/unit/test_metrics.py)
    assert symbolic == pytest.approx(numeric, rel=1e-6, abs=1e-14)


@pytest.mark.parametrize("config, name, options", CASES, ids=CASE_IDS)
def test_metric_on_the_default_box_is_finite_or_a_horizon_error(config, name, options):
    """With the plant's default bounds a metric either evaluates or says the horizon is too long."""
    metric = METRICS[name]()
    loop = config.plant.loop(nominal(config), config.default_box)
    try:
        value = as_float(metric.evaluate(loop, options))
    except HorizonError as error:
        assert "raise the minimum sampling period" in str(error)
        return
    assert math.isfinite(value)


@pytest.mark.parametrize("config", CONFIGS, ids=[c.id for c in CONFIGS])
def test_supports_accepts_every_option_variant(config):
    """supports() takes (loop, options) for every metric and returns a bool."""
    loop = config.plant.loop(nominal(config), narrow_box(config, nominal(config)))
    for cls in METRICS.values():
        for options in option_variants(cls):
            assert isinstance(cls().supports(loop, options), bool)
