"""feedtune.tuner.terms and feedtune.tuner.optimum on toy problems with known answers."""

import math

import casadi as ca
import numpy as np
import pytest

from feedtune.expr import Magnitude
from feedtune.tuner.builder import NlpBuilder
from feedtune.tuner.nlp import Problem
from feedtune.tuner.optimum import SAME_OPTIMUM_TOL, equal_optima
from feedtune.tuner.terms import add_bound, add_term, exact_value
from feedtune.tuner.types import Bound, Settings, Term, Variable


class Loop:
    discrete = False
    unrolled_steps = 0

    def __init__(self, values):
        self.values = values

    def stability_conditions(self):
        return [ca.MX(1.0)]

    def settling_conditions(self):
        return []

    def embedded_reads(self):
        return frozenset()  # no embedded numbers (Loop protocol)

    def stability_matrices(self):
        return {"closed_loop": ca.MX(-1.0)}


def test_a_magnitude_is_minimised_through_an_epigraph():
    """min |k − 3| (no fabs in the NLP): two rows −s·t ≤ k − 3 ≤ s·t; optimum k = 3."""
    builder = NlpBuilder([Variable("k", 1.0, 10.0)])
    k = ca.exp(builder.z[0])
    weight = builder.parameter("weight0", 1.0)
    f = add_term(builder, 0, Magnitude(k - 3), None, weight, 1.0, 1.0, [])
    assert builder.g.numel() == 2 and len(builder.extra) == 1
    problem = Problem([Variable("k", 1.0, 10.0, initial=8.0)], {}, Loop,
                      [Term("e", lambda loop: Magnitude(loop.values["k"] - 3))], [], {},
                      Settings(multistart=1))
    outcome = problem.solve()
    assert outcome.success and outcome.values["k"] == pytest.approx(3.0, rel=1e-7)
    assert f is not None


def test_a_bound_on_a_magnitude_from_below_is_squared():
    """|e| ≥ 2 is not convex: written e²/s² ≥ (2/s)², one row."""
    builder = NlpBuilder([Variable("k", 1.0, 10.0)])
    e = ca.exp(builder.z[0]) - 3
    add_bound(builder, 0, Magnitude(e), None, Bound("e", None, 2.0, None), None, [])
    assert builder.g.numel() == 1
    assert builder.lbg[0] == pytest.approx(1.0) and builder.ubg[0] == np.inf  # (2/2)²


def test_exact_value_of_a_magnitude_is_its_expression():
    x = ca.MX.sym("x")
    assert exact_value(Magnitude(x)) == (x, True)
    assert exact_value(x) == (x, False)


def test_equal_optima_lists_ties_best_first():
    variables = [Variable("k", 1.0, 10.0)]
    optima = [(0, -5.0, np.array([0.0])), (2, -5.0 * (1 + SAME_OPTIMUM_TOL / 2), np.array([1.0])),
              (3, -4.0, np.array([2.0]))]
    equal = equal_optima(optima, 2, 1.0, variables)
    assert [i for i, _ in equal] == [2, 0]
    assert equal[0][1]["k"] == pytest.approx(math.e)
    assert equal_optima(optima, 1, 1.0, variables) == []  # start 1 did not solve


@pytest.mark.parametrize("hessian", ["exact", "limited-memory"])
def test_flat_directions_with_either_hessian(hessian):
    """min (k1·k2 − 4)² is flat along k1·k2 = 4: both tunables flat; min (k1 − 2)² +
    (k2 − 3)² is not. With the limited-memory Hessian IPOPT builds no Hessian: the
    curvature comes from central differences of the exact gradient instead."""
    variables = [Variable("k1", 0.5, 10.0, initial=1.0), Variable("k2", 0.5, 10.0, initial=1.0)]
    settings = Settings(multistart=1, ipopt_options={"hessian_approximation": hessian})

    def solve(objective):
        outcome = Problem(variables, {}, Loop, [Term("f", objective)], [], {}, settings).solve()
        assert outcome.success, outcome.message
        return outcome

    flat = solve(lambda loop: (loop.values["k1"] * loop.values["k2"] - 4) ** 2)
    assert flat.flat_tunables == ["k1", "k2"]
    unique = solve(lambda loop: (loop.values["k1"] - 2) ** 2 + (loop.values["k2"] - 3) ** 2)
    assert unique.flat_tunables == []
    assert unique.values["k1"] == pytest.approx(2.0, rel=1e-6)


def test_the_next_hessian_goes_on_from_a_stable_end_point(monkeypatch):
    """A start the first Hessian leaves unsolved at a stable point (here: its iteration
    limit) is continued by the next one from that point, not solved again from the start
    (which, deterministic, would only end where the first run did)."""
    variables = [Variable("k1", 0.1, 10.0, initial=0.2), Variable("k2", 0.1, 10.0, initial=5.0)]
    settings = Settings(multistart=1, max_iter=3)
    problem = Problem(variables, {}, Loop,
                      [Term("f", lambda loop: (loop.values["k1"] - 2) ** 2
                            + 10 * (loop.values["k2"] - loop.values["k1"] ** 2) ** 2)],
                      [], {}, settings)
    problem.hessians = ["exact", "exact"]  # two attempts, as limited-memory then exact
    calls = []
    solve_from = Problem._solve_from

    def spy(self, start, started, solver, *args):
        out = solve_from(self, start, started, solver, *args)
        calls.append((args[0] if args else None, out))
        return out

    monkeypatch.setattr(Problem, "_solve_from", spy)
    outcome = problem.solve()
    assert len(calls) == 2
    first_end = calls[0][1][0]
    assert calls[0][1][1] == "Maximum_Iterations_Exceeded"
    resume = calls[1][0]
    assert resume is not None
    np.testing.assert_array_equal(resume[0][:2], first_end)
    assert outcome.starts[0].iterations == 6
    # it went on: the second run ends elsewhere, nearer the optimum (2, 4)
    second_end = calls[1][1][0]
    optimum = np.log([2.0, 4.0])
    assert np.linalg.norm(second_end - optimum) < np.linalg.norm(first_end - optimum)


def _two_gains_problem() -> Problem:
    """min (k1 − 2)² + (k2 − 3)² from one start (two tunables: IPOPT, not the scalar search)."""
    variables = [Variable("k1", 0.5, 10.0, initial=1.0), Variable("k2", 0.5, 10.0, initial=1.0)]
    return Problem(variables, {}, Loop,
                   [Term("f", lambda loop: (loop.values["k1"] - 2) ** 2
                         + (loop.values["k2"] - 3) ** 2)], [], {}, Settings(multistart=1))


def test_the_solvers_build_no_gradient_for_parameter_multipliers():
    """The tuner reads x, lam_g and lam_x of a solve, never the parameters' multipliers:
    CasADi's nlp_grad (the Lagrangian's gradient, 165k SX instructions on the bundled
    Ward-Leonard spec) is built by neither the cold nor the warm-start solver."""
    problem = _two_gains_problem()
    assert problem.solve().success
    for warm in (False, True):
        solver = problem._solver(problem.hessians[0], warm)
        assert solver.has_function("nlp_jac_g") and not solver.has_function("nlp_grad")


def test_what_the_nlp_sees_is_evaluated_once_per_point(monkeypatch):
    """The start is seen for the scales and for its objective scale, the end point for its
    feasibility and for the model gap: one numeric evaluation each (a scan of every peak
    and crossing on a frequency-domain problem)."""
    from feedtune.tuner.evaluation import Evaluator

    points = []
    evaluate = Evaluator.__call__

    def spy(self, z, p):
        points.append(np.asarray(z, dtype=float).tobytes())
        return evaluate(self, z, p)

    monkeypatch.setattr(Evaluator, "__call__", spy)
    outcome = _two_gains_problem().solve()
    assert outcome.success and outcome.values["k1"] == pytest.approx(2.0, rel=1e-6)
    assert len(points) == 2 and len(set(points)) == 2  # the start and the end point
