"""Solvers are built once per problem structure and reused: the numbers that differ between
specs are NLP parameters, and a result never depends on whether its solver was reused."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest

from example_specs import built, load_example, problems_built_only, without_timing
from feedtune.plants import plant_for
from feedtune.problem import tune
from feedtune.schema.spec import parse_spec
from feedtune.tuner import cache


def _variant(data: dict, **plant) -> dict:
    data = copy.deepcopy(data)
    data["plant"].update(plant)
    return data


#: the result of a spec tuned first in a cleared cache (a fresh solver), by its canonical
#: JSON, once per test process: :func:`_tune_after` tunes it to fill the cache, and a test
#: that only compares with such a result reads it here instead of tuning it again
_FRESH: dict[str, object] = {}


def _tune_after(first: dict | None, second: dict):
    """Tune ``second`` in a cleared cache, after ``first`` when given; its result and the
    cache counters."""
    cache.clear_solver_cache()
    if first is not None:
        _FRESH[json.dumps(first, sort_keys=True)] = tune(parse_spec(first))
    result = tune(parse_spec(second))
    return result, cache.solver_cache_info()


def _fresh(data: dict):
    """The result of ``data`` tuned in a cleared cache (its own fresh solver), once per
    test process; the cache is left as that tuning leaves it when it runs here."""
    key = json.dumps(data, sort_keys=True)
    if key not in _FRESH:
        cache.clear_solver_cache()
        _FRESH[key] = tune(parse_spec(data))
    return _FRESH[key]


@pytest.mark.parametrize("example, changes", [
    # minimum IAE (a step response summed over a horizon): the drive's blu and V_m, the
    # gain's box and the objective weight differ; the horizon (τ, T) does not
    ("koren-1979-min-iae-radius.json",
     {"plant": {"blu": 2e-5, "max_velocity": 0.05}, "gain_max": 150, "weight": 2.5}),
    # radial error with a damping constraint: τ, blu, V_m, the fixed period and the bound
    ("koren-1979-sampled-data.json",
     {"plant": {"time_constant": 0.025, "blu": 1e-5, "max_velocity": 0.05},
      "period": 0.02, "damping_min": 0.6}),
])
def test_reused_solver_gives_the_result_of_a_fresh_one(example, changes):
    a = load_example(example)
    b = _variant(a, **changes["plant"])
    b["name"] = a["name"] + "-b"
    if "gain_max" in changes:
        b["tunables"]["position_gain"]["max"] = changes["gain_max"]
    if "weight" in changes:
        b["objective"][0]["weight"] = changes["weight"]
    if "period" in changes:
        b["tunables"]["sampling_period"]["value"] = changes["period"]
    if "damping_min" in changes:
        b["constraints"][0]["min"] = changes["damping_min"]

    reused, info = _tune_after(a, b)
    assert info["hits"] == 1 and info["misses"] == 1, info  # b ran on a's solver
    fresh, info = _tune_after(None, b)
    assert info["hits"] == 0 and info["misses"] == 1, info
    assert reused.success and fresh.success
    assert without_timing(reused) == without_timing(fresh)


def _circles(data: dict, radius: float, feed: float) -> dict:
    """``data`` with every circle's radius [m] and feed [m/s] replaced."""
    data = copy.deepcopy(data)
    data["name"] += f"-r{radius}-v{feed}"
    for term in data["objective"] + data.get("constraints", []):
        if "radius" in term:
            term.update(radius=radius, feed=feed)
    return data


@pytest.mark.parametrize("example, radius, feed", [
    # ω = feed/radius in the objective (Koren's radial error): 8 mm at 40 mm/s → 15 mm at
    # 30 mm/s (ω 5 → 2 rad/s), both loops' ω and r parameters of one solver
    ("koren-1979-sampled-data.json", 0.015, 0.03),
    ("koren-1979-reference-pulse.json", 0.004, 0.03),
    # in the objective and in a constraint (Sato's roughness, decrease in radius ≤ 10 µm)
    ("sato-finish.json", 0.04, 0.06),
])
def test_specs_that_differ_in_their_circles_share_a_solver(example, radius, feed):
    """A circle's radius and feed enter the metrics through arithmetic only, so they are
    NLP parameters (feedtune.problem.LiftedOptions): a second circle runs on the first
    one's solver and gets the result a fresh solver gives."""
    a = load_example(example)
    b = _circles(a, radius, feed)
    reused, info = _tune_after(a, b)
    assert info["hits"] == 1 and info["misses"] == 1, info
    fresh, info = _tune_after(None, b)
    assert info["hits"] == 0 and info["misses"] == 1, info
    assert reused.success and fresh.success
    assert without_timing(reused) == without_timing(fresh)


def test_lifted_circle_gives_the_result_of_the_spec_numbers():
    """The objective evaluated on the tuner's loop with the circle as parameters equals
    the same metric evaluated with the spec's numbers embedded, at the same point."""
    import casadi as ca

    from feedtune.objectives import METRICS
    from feedtune.problem import LiftedOptions, resolve_tunables

    spec = parse_spec(load_example("koren-1979-sampled-data.json"))
    plant = plant_for(spec.plant)
    _, _, box = resolve_tunables(spec, plant)
    term = spec.objective[0]
    lifted = LiftedOptions()
    value = lifted.value_fn("objective0", METRICS[term.metric](), term)
    assert lifted.numbers == {"objective0.radius": 0.008, "objective0.feed": 0.04}
    gain = ca.MX.sym("gain")
    symbols = {name: ca.MX.sym(name) for name in lifted.numbers}
    values = {"position_gain": gain, "sampling_period": 0.015625}
    loop = lifted.make_loop(lambda own: plant.loop(values, box), symbols)
    expr = value(loop).expr
    assert set(ca.symvar(expr)) >= set(symbols.values())  # ω is no constant of the graph
    got = ca.Function("lifted", [gain, *symbols.values()], [expr])(18.0, 0.008, 0.04)
    plain = value(plant.loop(values, box)).expr
    expected = ca.Function("plain", [gain], [plain])(18.0)
    assert float(got) == pytest.approx(float(expected), rel=1e-14)


def test_a_number_that_shapes_the_graph_makes_a_new_solver():
    """τ sizes the step-response horizon of a minimum-IAE loop (its sample count): a
    different τ is a different structure, never a parameter of the same solver."""
    a = load_example("koren-1979-min-iae-radius.json")
    b = _variant(a, time_constant=0.03)
    with problems_built_only() as (_, made):  # the cache's look-ups are the builds'
        cache.clear_solver_cache()
        built(a)
        built(b)
        info = cache.solver_cache_info()
    assert info["hits"] == 0 and info["misses"] == 2, info
    assert made[0] == 2  # b's miss asked for a solver of its own


def test_one_free_gain_builds_no_solver_and_matches_ipopt():
    """Minimum IAE over the gain alone goes to the scalar search (feedtune.tuner.scalar):
    no IPOPT solver is built, and the tuned gain is IPOPT's to the search's resolution
    (Brent in ln K to ~5e-8, see tests/unit/test_scalar_search.py)."""
    ipopt = load_example("koren-1979-min-iae-radius.json")
    scalar = copy.deepcopy(ipopt)
    del scalar["solver"]["ipopt_options"]
    cache.clear_solver_cache()
    by_search = tune(parse_spec(scalar))
    assert by_search.solver.method == "brent"
    assert cache.solver_cache_info()["misses"] == 0
    by_ipopt = _fresh(ipopt)  # tuned first in a cleared cache above (the reused-solver test)
    assert by_ipopt.solver.method == "ipopt"
    assert by_search.tuned["position_gain"].value == pytest.approx(
        by_ipopt.tuned["position_gain"].value, rel=1e-7)


def test_same_spec_twice_reuses_and_repeats_the_result():
    a = load_example("koren-1979-sampled-data.json")
    cache.clear_solver_cache()
    first = tune(parse_spec(a))
    second = tune(parse_spec(a))
    assert cache.solver_cache_info()["hits"] == 1
    assert without_timing(first) == without_timing(second)


def test_cache_is_bounded_least_recently_used_first(monkeypatch):
    monkeypatch.setattr(cache, "SOLVER_CACHE_SIZE", 1)
    a = load_example("koren-1979-sampled-data.json")
    b = copy.deepcopy(a)
    b["solver"]["tol"] = 1e-8  # an nlpsol option: part of the key
    with problems_built_only():  # the cache's look-ups and evictions are the builds'
        cache.clear_solver_cache()
        for data in (a, b, a):
            built(data)
        info = cache.solver_cache_info()
    assert (info["hits"], info["misses"], info["size"]) == (0, 3, 1), info


def test_plant_numbers_as_expressions_give_the_same_loop():
    """``loop(values, ...)`` with the plant's own numbers among ``values`` as expressions
    equals the plain loop."""
    import casadi as ca

    data = load_example("koren-1979-min-iae-radius.json")
    plant = plant_for(parse_spec(data).plant)
    numbers = plant.numbers()
    assert set(numbers) == {"time_constant", "blu", "max_velocity"}
    symbols = {name: ca.MX.sym(name) for name in numbers}
    box = {"position_gain": (1.0, 200.0), "sampling_period": (0.01, 0.01)}
    gain = ca.MX.sym("gain")
    values = {"position_gain": gain, "sampling_period": 0.01}
    plain = plant.loop(values, box)
    lifted = plant.loop({**values, **symbols}, box)

    def outputs(loop):
        return [ca.vec(loop.state_matrix), loop.step_error_integrals.iae,
                loop.drive.max_pulse_rate]

    expected = ca.Function("plain", [gain], outputs(plain))(30.0)
    got = ca.Function("lifted", [gain, *symbols.values()], outputs(lifted))(30.0, *numbers.values())
    for e, g in zip(expected, got):
        assert np.asarray(g, dtype=float) == pytest.approx(np.asarray(e, dtype=float), rel=1e-14)
