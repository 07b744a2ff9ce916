"""Two free tunables and one |e|: the starts after the chosen one can no longer change are
solved by a root of e one tunable at a time (feedtune.tuner.nlp, ``Problem._root_along``).

IPOPT alone on the same spec is the reference. The chosen start is IPOPT's in both, so the
tuned point, every metric and the validation are the same bits; a later start solved by a
root ends where e = 0 to rounding: |e| ≤ 1e-9 BLU (a billionth of the drive's smallest
step), on the curve K(T) of zero radial error, so its gains may lie elsewhere on that
curve than IPOPT's from the same start (the optimum is not unique, and the result says so).
"""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest

import feedtune.tuner.nlp as nlp
from feedtune.problem import tune
from feedtune.schema.spec import parse_spec
from feedtune.tuner.calls import numeric
from feedtune.tuner.roots import RootSearch

#: batch spec 2 (benchmarks/batch_throughput.py): sampled data, K and T free, ζ ≥ 0.4; its
#: starts 1-3 reach e = 0, start 4 a local minimum of |e| on T's lower bound
CURVE = {"name": "servo-00002",
         "plant": {"type": "software_servo", "technique": "sampled_data",
                   "time_constant": 0.0171, "blu": 3.162e-06, "max_velocity": 0.02759},
         "tunables": {"position_gain": {"min": 1.0, "max": 300.0},
                      "sampling_period": {"min": 0.00252, "max": 0.034641}},
         "objective": [{"metric": "radial_error", "radius": 0.005231, "feed": 0.022995}],
         "constraints": [{"metric": "damping_ratio", "min": 0.4}],
         "solver": {"multistart": 4}}
#: batch spec 11: f_m·T ≥ 100 besides ζ ≥ 0.4; start 2's own T is below the encoder's bound,
#: so its line along K has no feasible point: the line along T enters at the bound's crossing
ENCODER = {"name": "servo-00011",
           "plant": {"type": "software_servo", "technique": "sampled_data",
                     "time_constant": 0.02924, "blu": 1.778e-06, "max_velocity": 0.02},
           "tunables": {"position_gain": {"min": 1.0, "max": 300.0},
                        "sampling_period": {"min": 0.004, "max": 0.026321}},
           "objective": [{"metric": "radial_error", "radius": 0.01749, "feed": 0.02}],
           "constraints": [{"metric": "damping_ratio", "min": 0.4},
                           {"metric": "encoder_ratio", "min": 100}],
           "solver": {"multistart": 4}}
#: batch spec 26: ζ ≥ 0.7 keeps e from 0: the optimum is a vertex (ζ's bound, T's lower
#: bound), 5.4e-5 m, unique
VERTEX = {"name": "servo-00026",
          "plant": {"type": "software_servo", "technique": "sampled_data",
                    "time_constant": 0.038236, "blu": 1.778e-06, "max_velocity": 0.03807},
          "tunables": {"position_gain": {"min": 1.0, "max": 300.0},
                       "sampling_period": {"min": 0.00252, "max": 0.026321}},
          "objective": [{"metric": "radial_error", "radius": 0.004, "feed": 0.031728}],
          "constraints": [{"metric": "damping_ratio", "min": 0.7}],
          "solver": {"multistart": 4}}
E_TOL_BLU = 1e-9


def _both(data: dict, monkeypatch):
    """(by IPOPT alone, as tuned) results of ``data``."""
    with monkeypatch.context() as patch:
        patch.setattr(nlp, "root_search_applies_along", lambda problem: False)
        ipopt = tune(parse_spec(copy.deepcopy(data)))
    return ipopt, tune(parse_spec(copy.deepcopy(data)))


def tuned_problem(data: dict, monkeypatch) -> nlp.Problem:
    """The Problem that tuning ``data`` solved (its first), after the tuning."""
    problems = []
    original = nlp.Problem.solve

    def keep(self, *args, **kwargs):
        problems.append(self)
        return original(self, *args, **kwargs)

    monkeypatch.setattr(nlp.Problem, "solve", keep)
    tune(parse_spec(copy.deepcopy(data)))
    return problems[0]


def _design(result) -> dict:
    """What a result says of the tuned design: everything but the solver's account of its
    starts and the optimum's evidence (and clocks, provenance)."""
    data = json.loads(result.model_dump_json())
    for key in ("solver", "optimum", "provenance"):
        data.pop(key, None)
    return data


@pytest.mark.parametrize("data", [CURVE, ENCODER], ids=["curve", "encoder-bound"])
def test_the_chosen_start_is_ipopts_and_later_starts_are_roots(data, monkeypatch):
    """The tuned point, metrics, constraints, stability and validation are IPOPT's bits;
    each later start solved by a root is feasible with |e| ≤ 1e-9 BLU; statuses and
    feasibility per start, which starts reached the best objective, uniqueness and the
    flat directions (the chosen start's reduced Hessian) are IPOPT's."""
    ipopt, along = _both(data, monkeypatch)
    blu = data["plant"]["blu"]
    assert _design(along) == _design(ipopt)
    assert along.success and along.validation["ok"]
    assert along.solver.method == ipopt.solver.method == "ipopt"
    methods = [s.method for s in along.solver.starts]
    assert methods[0] == "ipopt" and methods.count("root") >= 2
    assert all(s.method == "ipopt" for s in ipopt.solver.starts)
    for a, b in zip(ipopt.solver.starts, along.solver.starts):
        assert (a.status, a.feasible) == (b.status, b.feasible)
        if b.method == "root":
            assert b.objective <= E_TOL_BLU * blu
    assert along.optimum.starts == ipopt.optimum.starts
    assert along.optimum.unique is ipopt.optimum.unique is False
    assert along.optimum.flat == ipopt.optimum.flat == ["position_gain", "sampling_period"]


def test_a_start_that_can_still_be_chosen_is_ipopts(monkeypatch):
    """Where no start reaches e = 0 (the optimum a vertex of ζ's and T's bounds), every
    start may still be chosen: all are IPOPT's, and the result is IPOPT's in every field
    but the clocks."""
    ipopt, along = _both(VERTEX, monkeypatch)
    assert [s.method for s in along.solver.starts] == ["ipopt"] * 4
    strip = {"solve_time", "build_time", "evaluation_time"}

    def content(result):
        data = json.loads(result.model_dump_json())
        data["solver"] = {k: v for k, v in data["solver"].items() if k not in strip}
        for start in data["solver"]["starts"]:
            start.pop("solve_time")
        data.pop("provenance", None)
        return data

    assert content(along) == content(ipopt)
    assert along.optimum.unique is True


@pytest.mark.parametrize("best, settled", [
    (None, False),
    (((0, 0.0, 0), 0, None, "", ""), True),
    (((0, nlp.OBJECTIVE_TIE, 0), 0, None, "", ""), True),
    (((0, 2 * nlp.OBJECTIVE_TIE, 0), 0, None, "", ""), False),
    (((1, 0.0, 0), 0, None, "", ""), False),
], ids=["no-start-yet", "zero", "within-the-tie", "beyond-the-tie", "unsolved"])
def test_settled_is_where_no_later_start_can_be_chosen(best, settled):
    """A solved start whose objective is within ``_better``'s tie of 0 (OBJECTIVE_TIE) cannot be
    beaten by an objective ≥ 0; an unsolved one, or one above the tie, can."""
    assert nlp.Problem._settled(best) is settled
    if best is not None and best[0][0] == 0:
        assert nlp.Problem._better((0, 0.0, 1), best[0]) is not settled


def test_a_line_along_the_second_tunable_is_the_check_at_each_point(monkeypatch):
    """A line's grid (one call of the check mapped over its points, the first tunable held)
    is the bits of the check called at each full point."""
    problem = tuned_problem(ENCODER, monkeypatch)
    check = numeric(problem.evaluator.function)
    p = problem.param_values[:problem.evaluator.n_params]
    held = np.asarray(problem.starts[1], dtype=float)
    line = RootSearch.for_problem(problem, held=held, axis=1)
    assert len(line.grid) > 10
    for z, e in zip(line.grid, line.errors):
        terms = check.outputs(np.array([held[0], z]), p)[0]
        assert terms[0, 0] == e or (np.isnan(e) and np.isnan(terms[0, 0]))
        assert line.evaluate(z)[0] == e or np.isnan(e)
