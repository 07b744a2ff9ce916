"""The root search (feedtune.tuner.roots) against IPOPT on the same specs, and its grid
logic on plain numpy functions.

IPOPT (tol 1e-9, exact Hessian) on the epigraph of |e| is the reference: an independent
algorithm on the same functions. Its own spread of ln K between starts reaching one root
is 3e-12 (median) to 3e-10 (90 %) over the batch's specs (benchmarks/README.md, h-bst5),
so tuned gains are compared to 1e-9 in ln K, IPOPT's tolerance; |e| at a root to 1e-9 BLU
(the drive's resolution: a billionth of the smallest step the drive makes). On a
constraint's bound IPOPT stops within its tolerance outside the bound (ζ 6e-9 below 0.6
here, ≈ 2e-8 in ln K); the search's crossing is on the feasible side within 1e-12 of it.
"""

from __future__ import annotations

import copy
import json
import math

import numpy as np
import pytest

import feedtune.tuner.nlp as nlp
from feedtune.problem import tune
from feedtune.schema.spec import parse_spec
from feedtune.tuner.roots import ROOT_XTOL, RootSearch

from example_specs import EXAMPLES

#: a batch spec of kind 1 (benchmarks/batch_throughput.py, spec 10): sampled data, T fixed,
#: ζ ≥ 0.35; its third start (K = 47.7 1/s) is below ζ's bound: entered at the crossing
SAMPLED = {"name": "sampled", "plant": {"type": "software_servo", "technique": "sampled_data",
                                       "time_constant": 0.022361, "blu": 1e-6,
                                       "max_velocity": 0.1},
           "tunables": {"position_gain": {"min": 1.0, "max": 173.205},
                        "sampling_period": {"value": 0.02368307}},
           "objective": [{"metric": "radial_error", "radius": 0.015294, "feed": 0.083333}],
           "constraints": [{"metric": "damping_ratio", "min": 0.35}],
           "solver": {"multistart": 3}}
#: batch spec 195 (reference pulse, τ 50 ms, ζ ≥ 0.6): e = 0 lies beyond ζ's bound, so the
#: optimum is the gain where ζ = 0.6
ON_BOUND = {"name": "on-bound", "plant": {"type": "software_servo",
                                          "technique": "reference_pulse",
                                          "time_constant": 0.05, "blu": 1e-6,
                                          "max_velocity": 0.07248},
            "tunables": {"position_gain": {"min": 1.0, "max": 100.0}},
            "objective": [{"metric": "radial_error", "radius": 0.004, "feed": 0.072478}],
            "constraints": [{"metric": "damping_ratio", "min": 0.6}],
            "solver": {"multistart": 2}}
KOREN = json.loads((EXAMPLES / "koren-1979-reference-pulse.json").read_text(encoding="utf-8"))
LN_K_TOL = 1e-9  # see the module docstring
E_TOL_BLU = 1e-9


def _both(data: dict, monkeypatch):
    """(by IPOPT alone, by the root search) results of ``data``."""
    with monkeypatch.context() as patch:
        patch.setattr(nlp, "root_search_applies", lambda problem: False)
        ipopt = tune(parse_spec(copy.deepcopy(data)))
    return ipopt, tune(parse_spec(copy.deepcopy(data)))


def _gain(result) -> float:
    return result.tuned["position_gain"].value


@pytest.mark.parametrize("data", [KOREN, SAMPLED],
                         ids=["koren-reference-pulse", "sampled-infeasible-start"])
def test_each_start_is_ipopts_root(data, monkeypatch):
    """Every start ends where IPOPT's does (a root, or for the example's third start the
    gain's upper bound, where |e| falls towards it), solved by the root search, and the
    multistart's evidence (status, feasibility, which starts reached the best objective,
    uniqueness) is IPOPT's."""
    ipopt, roots = _both(data, monkeypatch)
    blu = data["plant"]["blu"]
    assert roots.solver.method == "root" and ipopt.solver.method == "ipopt"
    assert abs(math.log(_gain(roots)) - math.log(_gain(ipopt))) <= LN_K_TOL
    assert roots.objective <= E_TOL_BLU * blu
    assert [s.status for s in roots.solver.starts] == [s.status for s in ipopt.solver.starts]
    assert [s.feasible for s in roots.solver.starts] == [s.feasible for s in ipopt.solver.starts]
    for a, b in zip(ipopt.solver.starts, roots.solver.starts):
        assert abs(a.objective - b.objective) <= E_TOL_BLU * blu or (
            # on the box's bound: IPOPT stops within its tol (1e-9) inside it
            abs(a.objective - b.objective) <= 1e-7 * a.objective)
    assert roots.optimum.starts == ipopt.optimum.starts
    assert roots.optimum.unique == ipopt.optimum.unique is True
    assert roots.optimum.flat == ipopt.optimum.flat == []
    methods = [s.method for s in roots.solver.starts]
    assert methods.count("root") >= 2 and set(methods) <= {"root", "ipopt"}


def test_koren_reference_pulse_is_eq_36s_exact_gain(monkeypatch):
    """The example's description: the exact optimum is K = (1 + (ωτ)²)/(2τ) = 25.25 1/s
    (ω = V/R = 5 rad/s, τ = 20 ms); the root search lands on it to ROOT_XTOL in ln K."""
    result = tune(parse_spec(copy.deepcopy(KOREN)))
    assert abs(math.log(_gain(result)) - math.log(25.25)) <= 10 * ROOT_XTOL
    assert result.solver.starts[0].method == "root"


def test_optimum_on_a_constraints_bound(monkeypatch):
    """No root of e where ζ ≥ 0.6: the optimum is ζ's crossing, found by brentq on ζ's row,
    on the feasible side within 1e-12 of the bound, where IPOPT stops 6e-9 outside it."""
    ipopt, roots = _both(ON_BOUND, monkeypatch)
    damping = roots.constraints[0].value
    assert 0.6 <= damping <= 0.6 + 1e-12
    assert abs(ipopt.constraints[0].value - 0.6) <= 1e-8  # IPOPT's tol, relative to ζ ≈ 1
    # ζ falls by ≈ 0.5 a unit of ln K here: 1e-8 of ζ is 2e-8 of ln K
    assert abs(math.log(_gain(roots)) - math.log(_gain(ipopt))) <= 1e-7
    assert [s.method for s in roots.solver.starts] == ["root", "root"]
    assert roots.constraints[0].satisfied and roots.success
    # |e| there, in BLUs: IPOPT's lower by its bound's violation (6e-9 of ζ) only
    assert abs(roots.objective - ipopt.objective) <= 1e-4 * ON_BOUND["plant"]["blu"]
    assert roots.optimum.flat == ipopt.optimum.flat == []


def test_results_do_not_depend_on_what_was_solved_before(monkeypatch):
    """The root search keeps nothing between problems: a spec solved after another of
    the same structure gives the same bits as solved first (a batch's order and workers)."""
    first = tune(parse_spec(copy.deepcopy(SAMPLED)))
    other = copy.deepcopy(SAMPLED)
    other["plant"]["time_constant"] = 0.03
    tune(parse_spec(other))
    again = tune(parse_spec(copy.deepcopy(SAMPLED)))
    strip = {"solve_time", "build_time", "evaluation_time"}

    def content(result):
        data = json.loads(result.model_dump_json())
        data["solver"] = {k: v for k, v in data["solver"].items() if k not in strip}
        for start in data["solver"]["starts"]:
            start.pop("solve_time")
        data.pop("provenance", None)
        return data

    assert content(first) == content(again)


# -- the grid logic on plain numpy functions --------------------------------------------

def _search(e, starts, lower=0.0, upper=5.0, rows=lambda z: np.zeros(0)):
    """A RootSearch on the numpy error ``e(z)`` with bound rows ``rows(z)`` (≤ 0 holds)."""
    return RootSearch(lambda z: (float(e(z)), np.atleast_1d(rows(z)).astype(float), -1.0),
                      lower, upper, np.asarray(starts, dtype=float))


def test_two_feasible_runs_each_start_its_own_root():
    """e = (z − 0.5)(z − 3.5) with |z − 1.5| ≥ 0.5 (feasible z ≤ 1 or z ≥ 2): a start in
    each run finds that run's root; a start between the runs (z = 1.3, nearer the first)
    enters the first at its crossing z = 1, where |e| falls inward, and finds 0.5."""
    search = _search(lambda z: (z - 0.5) * (z - 3.5), [0.2, 4.6, 1.3],
                     rows=lambda z: 0.5 - abs(z - 1.5))
    found = [search.solve_from(z) for z in (0.2, 4.6, 1.3)]
    assert [f.z for f in found] == pytest.approx([0.5, 3.5, 0.5], abs=10 * ROOT_XTOL)
    assert not any(f.vertex for f in found)
    # the first run's root is searched once, its evaluations charged to both starts
    assert search.evaluations < len(search.grid) + sum(f.evaluations for f in found)


def test_no_root_in_the_run_the_crossing_is_the_optimum():
    """e = z − 4 with z ≤ 3: |e| least on the crossing z = 3, from a feasible start and from
    an infeasible one (z = 4.5, entered there), kept on the feasible side."""
    search = _search(lambda z: z - 4.0, [1.0, 4.5], rows=lambda z: z - 3.0)
    for start in (1.0, 4.5):
        found = search.solve_from(start)
        assert found.vertex
        assert 3.0 - 4 * ROOT_XTOL <= found.z <= 3.0


def test_box_bound_with_a_root_elsewhere():
    """e = (z − 1)·exp(−z) + 0.01 on [0, 8]: a root near z = 1 and |e| falling towards the
    box's upper end beyond its maximum at z = 2: a start right of the maximum ends on the
    bound (IPOPT's behaviour on Koren's reference pulse), one left of it at the root."""
    search = _search(lambda z: (z - 1) * math.exp(-z) + 0.01, [0.3, 4.0], upper=8.0)
    near, far = search.solve_from(0.3), search.solve_from(4.0)
    assert abs(near.z - 1 + 0.01 * math.e) < 1e-3 and not near.vertex  # root ≈ 0.973
    assert (near.z - 1) * math.exp(-near.z) + 0.01 == pytest.approx(0, abs=1e-15)
    assert far.z == 8.0 and far.vertex


@pytest.mark.parametrize("e, rows, start", [
    (lambda z: (z - 2) ** 2 + 1, lambda z: np.zeros(0), 3.0),
    (lambda z: z - 4.0, lambda z: np.array([z - 1.0, 2.0 - z]), 1.5),
    (lambda z: (z - 1) * (4 - z), lambda z: z - 3.0, 4.5),
], ids=["interior-minimum", "no-feasible-point", "crossing-a-minimum-with-a-root-inside"])
def test_declined_starts_are_left_to_ipopt(e, rows, start):
    """What the search does not solve it declines (None), for IPOPT: an interior minimum of
    |e| without a root (|e| = (z − 2)² + 1); no feasible point (z ≤ 1 and z ≥ 2); an
    infeasible start (z ≤ 3 holds, start 4.5) entering at a crossing where |e| rises inward
    while the run holds a root (z = 1): IPOPT from such starts went either way
    (benchmarks/README.md, h-bst6)."""
    search = _search(e, [start], rows=rows)
    assert search.solve_from(start) is None


def test_the_grid_in_one_mapped_call_is_the_grid_point_by_point(monkeypatch):
    """The grid's signed e and feasibility from the check Function mapped over the points
    (one call) are the bits of one call per point."""
    import dataclasses

    from feedtune.tuner import roots

    searches = []
    for_problem = roots.RootSearch.for_problem

    def spy(problem):
        searches.append(for_problem(problem))
        return searches[-1]

    monkeypatch.setattr(roots.RootSearch, "for_problem", spy)
    tune(parse_spec(copy.deepcopy(SAMPLED)))
    mapped = searches[0]
    assert mapped.evaluate_all is not None
    one_by_one = dataclasses.replace(mapped, evaluate_all=None)
    assert np.array_equal(mapped.grid, one_by_one.grid)
    assert mapped.errors.tobytes() == one_by_one.errors.tobytes()
    assert np.array_equal(mapped.feasible, one_by_one.feasible)
    assert not mapped.feasible.all() and mapped.feasible.any()  # ζ's bound cuts the grid


def test_an_undefined_error_inside_a_bracket_declines_the_start():
    """e = z − 2.6, not a number on (2.59, 2.61) around its root (between grid points, so
    the grid sees a plain sign change): brentq cannot finish, and the start is left to
    IPOPT rather than given a point that is not a root."""
    def e(z):
        return math.nan if 2.59 < z < 2.61 else z - 2.6

    search = _search(e, [1.0])
    assert search.errors[np.isfinite(search.errors)].size == search.grid.size
    assert search.solve_from(1.0) is None
