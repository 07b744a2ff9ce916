"""The scalar search (feedtune.tuner.scalar) against IPOPT on the same built problems, and
its grid logic on plain numpy functions.

IPOPT (tol 1e-9, exact Hessian) is the reference on Koren's one-gain problems: an
independent algorithm on the same functions. Brent's method resolves a smooth minimum from
values alone to about √ε·|ln K| ≈ 5e-8 in ln K (K ≈ 20–35 1/s), so gains are compared to
1e-7 relative; objectives, flat to second order there, to 1e-12 relative.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from example_specs import problems_built_only
from feedtune.objectives import METRICS
from feedtune.problem import build_plant, resolve_tunables
from feedtune.schema.spec import parse_spec
from feedtune.tuner import Bound, Problem, Settings, Term
from feedtune.tuner.scalar import ScalarSearch, applies

PLANT = {"type": "software_servo", "technique": "sampled_data", "time_constant": 0.02,
         "blu": 5e-6, "max_velocity": 0.04}
GAIN = {"min": 1, "max": 200}
K_TOL = 1e-7  # relative, see the module docstring
F_TOL = 1e-12


def _spec(objective, constraints=(), period={"value": 1 / 64}, multistart=8):
    return {"name": "scalar", "plant": PLANT,
            "tunables": {"position_gain": GAIN, "sampling_period": period},
            "objective": list(objective), "constraints": list(constraints),
            "solver": {"multistart": multistart}}


def _problem(data: dict, horizon_scale: float = 1.0) -> Problem:
    """The tuner's Problem for ``data``, built as feedtune.problem builds it, solved by
    IPOPT (the reference here: the search is called directly on the same problem)."""
    spec = parse_spec(data)
    plant = build_plant(spec)
    variables, fixed, box = resolve_tunables(spec, plant)

    def value(term):
        metric = METRICS[term.metric]()
        return lambda loop: metric.evaluate(loop, term)

    def make_loop(values):
        return plant.loop(values, box, horizon_scale=horizon_scale)

    objective = [Term(t.metric, value(t), t.weight) for t in spec.objective]
    constraints = [Bound(c.metric, value(c), c.min, c.max) for c in spec.constraints]
    return Problem(variables, fixed, make_loop, objective, constraints, {},
                   Settings(multistart=spec.solver.multistart, scalar_search=False),
                   numbers=plant.numbers())


#: (problem, IPOPT's outcome) by the spec's hash (key order and spelled-out defaults
#: ignored), once per test process: the reference of the tests below that solve one spec
_SOLVED: dict[str, tuple] = {}


def _solved(data: dict) -> tuple:
    """(:func:`_problem` of ``data``, its IPOPT solution), built and solved once per test
    process for every test of the same spec (``time`` absolute is the iae default: the
    grid test and the tuner's test solve one problem). Read them only; a test may run the
    search on the problem, which reads it."""
    key = parse_spec(data).sha256()
    if key not in _SOLVED:
        problem = _problem(data)
        _SOLVED[key] = problem, problem.solve()
    return _SOLVED[key]


def _seen(problem, z):
    """What the problem's NLP sees at ``z`` [ln tunable]."""
    return problem.evaluator(np.asarray(z, dtype=float), problem.param_values)


def _search(problem):
    """(search, best z, objective the NLP sees there, every start's return status)."""
    search = ScalarSearch.for_problem(problem)
    assert search is not None
    runs = [search.solve_from(start) for start in search.start_points()]
    best = min(runs, key=lambda r: _seen(problem, r[0]).objective)
    return search, best[0], _seen(problem, best[0]).objective, [r[1] for r in runs]


@pytest.mark.parametrize("time", ["absolute", "natural"])
def test_koren_iae_gain_equals_ipopt(time):
    """Min IAE at T = 1/64 s (benchmarks/koren_vs_scipy.py case 3; natural time as in
    examples/koren-1979-min-iae-radius.json): one grid minimum, refined once, at IPOPT's K."""
    problem, ipopt = _solved(_spec([{"metric": "iae", "time": time}]))
    search, z, objective, statuses = _search(problem)
    assert statuses == ["Solve_Succeeded"]  # unimodal on the grid: one refinement
    assert math.exp(z[0]) == pytest.approx(ipopt.values["position_gain"], rel=K_TOL)
    seen = _seen(problem, np.log([ipopt.values["position_gain"]])).objective
    assert objective == pytest.approx(seen, rel=F_TOL)
    assert objective <= seen * (1 + F_TOL)
    assert search.flat_tunables(z, "position_gain") == ipopt.flat_tunables == []
    # a deterministic count, not a time: the grid (8 starts + 2 ends) and Brent's evaluations
    assert search.evaluations <= 40


def test_constraint_active_optimum_is_on_the_boundary():
    """ζ ≥ 0.8 cuts off the IAE optimum (ζ ≈ 0.63 at K = 33.5 1/s): the optimum is the
    gain where ζ = 0.8, found by bisection to 1e-10 in ln K and kept on the feasible side.
    It is a vertex (the constraint fixes the only tunable), so not flat."""
    problem = _problem(_spec([{"metric": "iae"}], [{"metric": "damping_ratio", "min": 0.8}]))
    ipopt = problem.solve()
    search, z, _, statuses = _search(problem)
    assert statuses[0] == "Solve_Succeeded"
    assert math.exp(z[0]) == pytest.approx(ipopt.values["position_gain"], rel=K_TOL)
    seen = _seen(problem, z)
    damping, conditions = seen.bounds[0], seen.stability
    assert 0.8 <= damping <= 0.8 * (1 + 1e-8)  # on the bound, from the feasible side
    assert np.all(np.asarray(conditions) > 0)
    assert search.flat_tunables(z, "position_gain") == []
    # the boundary is bisected (≈ 33 halvings from a grid cell to 1e-10), then recognised
    # as the optimum by the objective rising into the feasible side: no Brent iterations
    assert search.evaluations <= 50


def test_settling_bound_everywhere_leaves_the_horizon_to_the_tuner():
    """Delay 1, K ≥ 40 1/s, T = 1/64 s: every loop of the box rings longer than the first
    horizon's settling conditions allow (spectral radius ≥ 0.955 > 1e-4^(1/92)), so no grid
    point is feasible: the search declines and IPOPT reports the problem infeasible where
    the settling conditions bind, which makes the tuner lengthen the horizon. 4 times
    longer, the search finds IPOPT's optimum on the gain's lower bound."""
    data = {"name": "lightly-damped", "plant": dict(PLANT, computation_delay=1),
            "tunables": {"position_gain": {"min": 40.0, "max": 200},
                         "sampling_period": {"value": 1 / 64}},
            "objective": [{"metric": "iae"}], "solver": {"multistart": 2}}
    with problems_built_only():  # whether the search can solve it: no IPOPT solver needed
        problem = _problem(data)
        assert not ScalarSearch.for_problem(problem).solvable
    longer = _problem(data, horizon_scale=4.0)
    ipopt = longer.solve()
    _, z, _, statuses = _search(longer)
    assert statuses == ["Solve_Succeeded"]
    assert math.exp(z[0]) == pytest.approx(ipopt.values["position_gain"], rel=K_TOL)
    assert math.exp(z[0]) == pytest.approx(40.0, rel=1e-9)


@pytest.mark.parametrize("data", [
    _spec([{"metric": "iae"}], period={"min": 0.005, "max": 0.03}),  # two free tunables
    _spec([{"metric": "radial_error", "radius": 0.008, "feed": 0.04}]),  # |e|: an epigraph slack
], ids=["two-tunables", "epigraph"])
def test_scalar_search_declines_what_it_cannot_solve(data):
    with problems_built_only():  # the Problem as the tuner builds it, IPOPT's solver aside
        problem = _problem(data)
        assert not applies(problem)
        assert ScalarSearch.for_problem(problem) is None


def _numpy_search(f, lower, upper, starts, count=8, feasible=None):
    """A ScalarSearch on a numpy function of z (feasible where ``feasible(z)``)."""
    def evaluate(zs):
        zs = np.atleast_1d(zs)
        ok = np.ones(zs.shape, dtype=bool) if feasible is None else feasible(zs)
        return f(zs), np.where(ok, -1.0, 1.0)

    return ScalarSearch(evaluate, lower, upper, np.asarray(starts, dtype=float), count)


def test_every_grid_minimum_is_refined_and_found():
    """f = cos(3z) + 0.1z on [0, 6] has minima near z = π/3·(2k+1) − small shift: each
    grid minimum is refined to the local minimum of its bracket (f' = 0 to Brent's
    resolution), the lowest first."""
    def f(z):
        return np.cos(3 * z) + 0.1 * z

    search = _numpy_search(f, 0.0, 6.0, np.linspace(0.3, 5.7, 19))
    starts = search.start_points()
    assert len(starts) == 3
    found = sorted(search.solve_from(s)[0][0] for s in starts)
    # f' = −3 sin 3z + 0.1 = 0 with f'' = −9 cos 3z > 0
    expected = [(math.pi - math.asin(0.1 / 3) + 2 * math.pi * k) / 3 for k in range(3)]
    np.testing.assert_allclose(found, expected, atol=1e-7)
    assert search.refine(float(starts[0][0])).z[0] == pytest.approx(expected[0], abs=1e-7)


def test_minimum_at_a_bound_of_the_box_is_a_vertex():
    search = _numpy_search(lambda z: (z - 3.0) ** 2, 0.0, 2.0, [0.5, 1.0, 1.5])
    (start,) = search.start_points()
    z, status, iterations, _, _ = search.solve_from(start)
    assert status == "Solve_Succeeded"
    assert z[0] == 2.0  # the bound itself (IPOPT may end 1e-8 beyond it: bound relaxation)
    assert iterations == 0  # rising into the box from the bound: no Brent iteration needed
    assert search.flat_tunables(z, "x") == []


def test_flat_objective_is_reported_flat_and_curved_is_not():
    """Curvature of f/|f(start)| below FLAT_CURVATURE (1e-6) in ln x: a flat direction."""
    flat = _numpy_search(lambda z: 1.0 + 1e-9 * (z - 1.0) ** 2, 0.0, 2.0, [0.5, 1.5])
    z, *_ = flat.solve_from(flat.start_points()[0])
    assert flat.flat_tunables(z, "x") == ["x"]
    curved = _numpy_search(lambda z: 1.0 + 1e-3 * (z - 1.0) ** 2, 0.0, 2.0, [0.5, 1.5])
    z, *_ = curved.solve_from(curved.start_points()[0])
    assert z[0] == pytest.approx(1.0, abs=1e-6)
    assert curved.flat_tunables(z, "x") == []


def test_no_feasible_grid_point_is_not_solvable():
    search = _numpy_search(lambda z: z ** 2, 0.0, 1.0, [0.5], feasible=lambda z: z > 2)
    assert not search.solvable
    assert search.start_points().size == 0


def test_feasibility_boundary_between_grid_points_is_located():
    """The minimum of (z − 1)² restricted to z ≤ 0.7 lies on the boundary between grid
    points 0.5 and 1.0: bisected to 1e-10, the feasible side kept."""
    search = _numpy_search(lambda z: (z - 1.0) ** 2, 0.0, 2.0, [0.5, 1.0, 1.5],
                           feasible=lambda z: z <= 0.7)
    z, status, *_ = search.solve_from(search.start_points()[0])
    assert status == "Solve_Succeeded"
    assert 0.7 - 2e-10 <= z[0] <= 0.7
    assert search.flat_tunables(z, "x") == []


def test_tuner_uses_the_scalar_search_for_one_free_tunable():
    """Through feedtune.problem.tune: case 3 is solved by the scalar search (no IPOPT),
    at IPOPT's gain, with a unique optimum and a validation that passes."""
    from feedtune.problem import tune

    data = _spec([{"metric": "iae"}])
    _, ipopt = _solved(data)  # the grid test's [absolute] problem
    result = tune(parse_spec(data))
    assert result.solver.method == "brent"
    assert result.success and result.validation["ok"]
    assert result.tuned["position_gain"].value == pytest.approx(
        ipopt.values["position_gain"], rel=K_TOL)
    assert result.optimum.unique is True


def test_a_start_over_its_time_limit_stops_with_ipopts_status():
    """solver.time_limit bounds each start, as IPOPT's max_wall_time does: a search whose
    start's clock is already past it stops at once, at its start, with
    Maximum_WallTime_Exceeded (the tuner's status time_limit)."""
    import time

    search = _numpy_search(lambda z: (z - 1.0) ** 2, 0.0, 2.0, [0.5, 1.5])
    search.time_limit = 1.0
    (start,) = search.start_points()
    z, status, iterations, _, _ = search.solve_from(start, time.perf_counter() - 2.0)
    assert (status, iterations, z[0]) == ("Maximum_WallTime_Exceeded", 0, start[0])
    z, status, *_ = search.solve_from(start, time.perf_counter())  # within the limit
    assert status == "Solve_Succeeded" and z[0] == pytest.approx(1.0, abs=1e-6)


def test_no_feasible_grid_point_leaves_the_problem_to_ipopt():
    """ζ = 0.707 as an equality (Koren's Fig 6 locus, feedtune.charts.koren): no grid point
    can hold it, so the tuner does not let the scalar search call it infeasible; IPOPT
    solves it, on the equality."""
    from feedtune.problem import tune

    data = _spec([{"metric": "natural_frequency", "goal": "maximize"}],
                 [{"metric": "damping_ratio", "min": 0.707, "max": 0.707}], multistart=4)
    result = tune(parse_spec(data))
    assert result.solver.method == "ipopt"
    assert result.success
    assert result.metrics["damping_ratio"].value == pytest.approx(0.707, abs=1e-6)
