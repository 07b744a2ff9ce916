"""feedtune.tuner.cache: one solver per graph structure, keyed by what the graph computes."""

import casadi as ca

from feedtune.tuner import cache


def _nlp(constant: float) -> ca.Function:
    x, p = ca.MX.sym("x"), ca.MX.sym("p")
    return ca.Function("nlp", [x, p], [(x - p) ** 2 + constant * x, x], ["x", "p"], ["f", "g"])


OPTIONS = {"ipopt": {"print_level": 0, "sb": "yes"}, "print_time": False}


def test_same_graph_same_key_other_constant_other_key():
    key = cache.structure_key({"nlp": _nlp(1.0)}, OPTIONS, True)
    assert key == cache.structure_key({"nlp": _nlp(1.0)}, OPTIONS, True)
    assert key != cache.structure_key({"nlp": _nlp(2.0)}, OPTIONS, True)
    assert key != cache.structure_key({"nlp": _nlp(1.0)}, OPTIONS, False)
    assert key != cache.structure_key({"nlp": _nlp(1.0)}, {**OPTIONS, "print_time": True}, True)


def test_a_second_build_of_the_same_structure_reuses_the_solver():
    cache.clear_solver_cache()
    first = cache.cached_build({"nlp": _nlp(1.0)}, {}, OPTIONS, True, has_nlp=True)
    second = cache.cached_build({"nlp": _nlp(1.0)}, {}, OPTIONS, True, has_nlp=True)
    assert not first.reused and second.reused and second.solver is first.solver
    assert cache.solver_cache_info() == {"hits": 1, "misses": 1, "size": 1,
                                         "maxsize": cache.SOLVER_CACHE_SIZE}
    solution = second.solver(x0=0, p=3.0, lbg=-10, ubg=10)
    assert abs(float(solution["x"]) - 2.5) < 1e-6  # minimises (x − 3)² + x (IPOPT tol 1e-8)


def test_without_free_tunables_nothing_is_built_or_cached():
    cache.clear_solver_cache()
    built = cache.cached_build({"nlp": _nlp(1.0)}, {}, OPTIONS, True, has_nlp=False)
    assert built.solver is None and cache.solver_cache_info()["size"] == 0


def test_the_least_recently_used_structure_is_dropped(monkeypatch):
    monkeypatch.setattr(cache, "SOLVER_CACHE_SIZE", 2)
    cache.clear_solver_cache()
    for constant in (1.0, 2.0, 3.0):
        cache.cached_build({"nlp": _nlp(constant)}, {}, OPTIONS, False, has_nlp=True)
    assert cache.solver_cache_info()["size"] == 2
    again = cache.cached_build({"nlp": _nlp(1.0)}, {}, OPTIONS, False, has_nlp=True)
    assert not again.reused  # 1.0 was dropped first
