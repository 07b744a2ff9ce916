"""Contract of exact-only plants (a discrete simulation, not a linear loop: Tian's pulse
generator) and of the metrics that read them; enrolled from the registries like the linear
contracts (contract_cases.EXACT_CONFIGS, exact_metric_cases)."""

from __future__ import annotations

import math

import casadi as ca
import pytest

from contract_cases import (EXACT_CONFIG_IDS, EXACT_CONFIGS, exact_metric_cases, exact_nominal,
                            option_variants)
from feedtune.objectives import METRICS
from feedtune.plants.base import Tunable
from feedtune.tuner.nlp import Problem
from feedtune.tuner.search import SearchProblem, problem_class

CASES = exact_metric_cases()
CASE_IDS = [f"{name}-{config.id}-{options.model_dump()}" for config, name, options in CASES]


def test_there_is_an_exact_plant():
    assert EXACT_CONFIGS and CASES


@pytest.mark.parametrize("config", EXACT_CONFIGS, ids=EXACT_CONFIG_IDS)
def test_exact_loop_declares_itself_and_settles_at_the_nominal_point(config):
    for name, tunable in config.tunables.items():
        assert isinstance(tunable, Tunable) and 0 < tunable.min < tunable.max, name
    loop = config.plant.loop(exact_nominal(config), config.default_box)
    assert loop.exact_only is True
    assert problem_class(loop) is SearchProblem
    stability = loop.stability()
    assert stability["stable"] is True and stability["domain"] == "pulse"


@pytest.mark.parametrize("config", EXACT_CONFIGS, ids=EXACT_CONFIG_IDS)
def test_exact_loop_refuses_symbols(config):
    """Built from CasADi symbols (as the NLP would), the loop exists but its simulation
    raises TypeError: never a wrong number."""
    names = list(config.tunables)
    z = ca.MX.sym("z", len(names))
    loop = config.plant.loop({n: ca.exp(z[i]) for i, n in enumerate(names)}, config.default_box)
    with pytest.raises(TypeError):
        loop.response


@pytest.mark.parametrize("config", EXACT_CONFIGS, ids=EXACT_CONFIG_IDS)
def test_linear_loop_metrics_decline_exact_loops(config):
    loop = config.plant.loop(exact_nominal(config), config.default_box)
    for name, cls in METRICS.items():
        for options in option_variants(cls):
            supported = cls().supports(loop, options)
            assert isinstance(supported, bool)
            if supported:
                assert any(n == name for c, n, _ in CASES if c is config)


@pytest.mark.parametrize("config, name, options", CASES, ids=CASE_IDS)
def test_exact_metric_is_finite_and_refuses_symbols(config, name, options):
    metric = METRICS[name]()
    loop = config.plant.loop(exact_nominal(config), config.default_box)
    value = metric.evaluate(loop, options)
    assert isinstance(value, float) and math.isfinite(value)
    assert metric.optimisable(loop, options) is True  # by the search tuner
    assert metric.unit_of(options, config.plant.position_unit)
    names = list(config.tunables)
    z = ca.MX.sym("z", len(names))
    symbolic = config.plant.loop({n: ca.exp(z[i]) for i, n in enumerate(names)}, config.default_box)
    with pytest.raises(TypeError):
        metric.evaluate(symbolic, options)


def test_linear_loops_still_get_the_nlp():
    from contract_cases import CONFIGS, nominal

    config = CONFIGS[0]
    assert problem_class(config.plant.loop(nominal(config), config.default_box)) is Problem
