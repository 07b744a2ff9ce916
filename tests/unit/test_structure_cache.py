"""A problem's symbolic part (loop, metric values, Functions) is built once per structure,
found by a key computed from the spec before anything is built (feedtune.tuner.structure,
feedtune.problem.structure_key): a later spec of the same structure computes only its own
numbers, and gets the result a fresh build gives."""

from __future__ import annotations

import copy

import pytest

from example_specs import built, load_example, problems_built_only, without_timing
from feedtune.problem import tune
from feedtune.schema.spec import parse_spec
from feedtune.tuner import cache


def _changed(data: dict, plant: dict | None = None, **paths) -> dict:
    """``data`` with plant fields replaced and ``section__index__field=value`` changes."""
    data = copy.deepcopy(data)
    data["name"] += "-changed"
    data["plant"].update(plant or {})
    for path, value in paths.items():
        section, index, field = path.split("__")
        data[section][int(index) if index.isdigit() else index][field] = value
    return data


#: the same structure: only numbers the NLP takes as parameters differ (blu, V_m, the
#: circle, the weight, the damping bound; for the reference-pulse loop τ too)
SAME = [
    ("koren-1979-sampled-data.json",
     dict(plant={"blu": 2e-6, "max_velocity": 0.06}, objective__0__radius=0.012,
          objective__0__feed=0.03, objective__0__weight=3.0, constraints__0__min=0.6)),
    ("koren-1979-reference-pulse.json",
     dict(plant={"time_constant": 0.03, "blu": 2e-6}, objective__0__radius=0.01)),
]


@pytest.mark.parametrize("example, changes", SAME)
def test_a_spec_of_a_known_structure_builds_no_graph_and_gets_the_fresh_result(example, changes):
    a = load_example(example)
    b = _changed(a, **changes)
    cache.clear_solver_cache()
    tune(parse_spec(a))
    reused = tune(parse_spec(b))
    info = cache.structure_cache_info()
    assert (info["hits"], info["misses"]) == (1, 1), info  # b took a's symbolic part
    cache.clear_solver_cache()
    fresh = tune(parse_spec(b))
    assert cache.structure_cache_info()["hits"] == 0
    assert reused.success and fresh.success
    assert without_timing(reused) == without_timing(fresh)


def _keys(data: dict) -> tuple[list[str], set[str]]:
    """The structure keys ``tune`` handed the Problem, and the solver-cache keys (hashes of
    the serialized graphs) of a fresh build of ``data``'s problem: built as ``tune`` builds
    it, up to its solve (``problems_built_only``: the graphs and their keys are the build's;
    IPOPT's solver, not part of the key, and the solve are not what these tests compare)."""
    with problems_built_only() as (seen, made):
        cache.clear_solver_cache()
        built(data)
        graphs = set(cache._cache)
    assert made[0] == len(graphs)  # a solver was asked for each graph keyed
    return seen, graphs


#: the keys of a fresh tuning of each unchanged example, by file name: the pairs below
#: share their first spec (three pairs start from koren-1979-min-iae-radius), whose fresh
#: tuning gives the same keys each time (the SAME pairs assert that two fresh tunings of
#: one structure give one key and one graph), so it is built once per test process
_EXAMPLE_KEYS: dict[str, tuple[list[str], set[str]]] = {}


def _example_keys(example: str) -> tuple[list[str], set[str]]:
    """:func:`_keys` of the bundled ``example`` as it is, once per test process."""
    if example not in _EXAMPLE_KEYS:
        _EXAMPLE_KEYS[example] = _keys(load_example(example))
    return _EXAMPLE_KEYS[example]


#: pairs whose graphs differ or may differ: τ sizes the minimum-IAE loop's step-response
#: horizon, a fixed period its smallest period, a second side of a bound the rows, a metric option
#: (the input) the expression
DIFFERENT = [
    ("koren-1979-min-iae-radius.json", dict(plant={"time_constant": 0.03})),
    ("koren-1979-min-iae-radius.json", dict(tunables__sampling_period__value=0.005)),
    ("koren-1979-min-iae-radius.json", dict(objective__0__time="absolute")),
    ("koren-1979-sampled-data.json", dict(constraints__0__max=0.9)),
    ("sato-finish.json", dict(constraints__0__min=1e-7)),
]


@pytest.mark.parametrize("example, changes", SAME + DIFFERENT)
def test_equal_structure_keys_mean_equal_graphs(example, changes):
    """The key is sound: two specs with one structure key have one serialized graph (the
    solver cache's key, computed from the built Functions), and every pair in DIFFERENT
    whose graphs differ has two keys."""
    a = load_example(example)
    b = _changed(a, **changes)
    keys_a, graphs_a = _example_keys(example)
    keys_b, graphs_b = _keys(b)
    assert keys_a and keys_b and None not in keys_a + keys_b
    assert graphs_a and graphs_b  # IPOPT solvers were asked for: there are graphs to compare
    if keys_a == keys_b:
        assert graphs_a == graphs_b
    if graphs_a != graphs_b:
        assert keys_a != keys_b
    if (example, changes) in SAME:
        assert keys_a == keys_b  # what the cache is for: these share a structure
    if (example, changes) == DIFFERENT[0]:
        assert graphs_a != graphs_b  # τ sizes the horizon: the implication above is tested


def test_structure_cache_is_bounded_least_recently_used_first(monkeypatch):
    monkeypatch.setattr(cache, "STRUCTURE_CACHE_SIZE", 1)
    a = load_example("koren-1979-sampled-data.json")
    b = _changed(a, constraints__0__max=0.9)
    with problems_built_only():  # the structure cache's look-ups are the builds'
        cache.clear_solver_cache()
        for data in (a, b, a):
            built(data)
        info = cache.structure_cache_info()
    assert (info["hits"], info["misses"], info["size"]) == (0, 3, 1), info


def test_numbers_the_graph_does_not_read_share_its_structure():
    """τ and the sampling period size the sampled loop's horizon, smallest period and band
    (feedtune.plants.software_servo.embedded_numbers); its graph reads the horizon only for
    step integrals and the band only for frequency metrics. Koren's radial-error spec reads
    neither, so a spec with another τ and period takes the first one's structure (the
    loop recorded no read: feedtune.loops.loop.EmbeddedNumber) and gets the fresh result;
    the min-IAE spec sums its step response over the horizon, so another τ builds anew."""
    a = load_example("koren-1979-sampled-data.json")
    b = _changed(a, plant={"time_constant": 0.03}, tunables__sampling_period__value=0.01)
    cache.clear_solver_cache()
    tune(parse_spec(a))
    reused = tune(parse_spec(b))
    info = cache.structure_cache_info()
    assert (info["hits"], info["misses"]) == (1, 1), info
    cache.clear_solver_cache()
    fresh = tune(parse_spec(b))
    assert reused.success and fresh.success
    assert without_timing(reused) == without_timing(fresh)

    iae = load_example("koren-1979-min-iae-radius.json")
    with problems_built_only():  # the structure cache's counters are the builds'
        cache.clear_solver_cache()
        built(iae)
        built(_changed(iae, plant={"time_constant": 0.03}))
        info = cache.structure_cache_info()
    assert (info["hits"], info["misses"]) == (0, 2), info
