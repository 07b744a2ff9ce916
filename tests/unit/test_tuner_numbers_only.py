"""A problem of a structure built before makes only its numbers (feedtune.tuner.builder:
``NlpBuilder.symbolic``, :class:`~feedtune.tuner.builder.Lazy`): none of its objective,
bound or stability rows is built as a CasADi expression, and its parameter values, row
and variable bounds are those a fresh build computes."""

import casadi as ca
import numpy as np
import pytest

from feedtune.expr import Magnitude
from feedtune.tuner import cache
from feedtune.tuner.builder import Lazy, NlpBuilder
from feedtune.tuner.nlp import Problem
from feedtune.tuner.types import Bound, Settings, Term, Variable


class Loop:
    """Poles k − limit ± j [1/s]: stable for k below the plant number ``limit``."""

    discrete = False
    unrolled_steps = 0

    def __init__(self, values):
        self.values = values

    def stability_conditions(self):
        return [self.values["limit"] - self.values["k"]]

    def settling_conditions(self):
        return [self.values["limit"] + 1 - self.values["k"]]

    def embedded_reads(self):
        return frozenset()  # no embedded numbers (Loop protocol)

    def stability_matrices(self):
        real = self.values["k"] - self.values["limit"]
        return {"closed_loop": ca.vertcat(ca.horzcat(real, -1), ca.horzcat(1, real))}


def _problem(target: float, limit: float, key: str | None) -> Problem:
    """Two groups (the worst-group epigraph), a magnitude and a plain term, a plain bound
    and a magnitude bound: every Lazy piece the tuner has. ``target`` and ``limit`` are
    plant numbers (NLP parameters): one structure for every value."""
    objective = [Term("e", lambda loop: Magnitude(loop.values["k"] - loop.values["target"]),
                      1.0, 0),
                 Term("k", lambda loop: 0.1 * loop.values["k"], 2.0, 1)]
    constraints = [Bound("k²", lambda loop: loop.values["k"] ** 2, 0.5, None),
                   Bound("|k − 1|", lambda loop: Magnitude(loop.values["k"] - 1), None, 20.0)]
    numbers = {"limit": limit, "target": target}  # the exact evaluation passes k alone
    return Problem([Variable("k", 0.5, 9.0, initial=1.0)], {},
                   lambda values: Loop({**numbers, **values}), objective, constraints,
                   {}, Settings(multistart=2, scalar_search=False), numbers=numbers,
                   structure_key=key)


@pytest.fixture
def built(monkeypatch):
    """The number of Lazy expressions built, counted from here on."""
    count = [0]
    build = Lazy.build

    def counted(self):
        count[0] += 1
        return build(self)

    monkeypatch.setattr(Lazy, "build", counted)
    cache.clear_solver_cache()
    yield count
    cache.clear_solver_cache()


def test_a_problem_of_a_built_structure_builds_no_rows_and_has_the_fresh_numbers(built):
    first = _problem(3.0, 8.0, "numbers-only")
    assert built[0] > 0  # the first of its structure builds the graph
    built[0] = 0
    second = _problem(4.0, 7.5, "numbers-only")
    assert cache.structure_cache_info()["hits"] == 1
    assert built[0] == 0
    fresh = _problem(4.0, 7.5, None)  # the same numbers, built from scratch
    assert built[0] > 0
    for name in ("param_values", "lbw", "ubw", "lbg", "ubg", "slot_defaults"):
        np.testing.assert_array_equal(getattr(second, name), getattr(fresh, name), err_msg=name)
    assert second.f_scale == fresh.f_scale
    a, b = second.solve(), fresh.solve()
    assert a.success and b.success and a.values == b.values and a.objective == b.objective
    assert first.param_values.shape == second.param_values.shape


def test_a_builder_that_is_not_symbolic_counts_rows_without_building_them():
    def fail():
        raise AssertionError("built")

    builder = NlpBuilder([Variable("k", 1.0, 10.0)], symbolic=False)
    t = builder.variable("slack", 0.0, ca.inf, Lazy(fail))
    rows = builder.constrain_all(Lazy(fail, size=3), -1.0, 2.0)
    assert rows == range(0, 3) and isinstance(t, ca.MX)
    np.testing.assert_array_equal(builder.lbg, [-1.0] * 3)
    np.testing.assert_array_equal(builder.ubw, [np.log(10.0), np.inf])
    assert builder.expression(Lazy(fail)) is None and builder.extra_start == [None]


def test_a_symbolic_builder_builds_a_lazy_expression_once():
    made = []
    lazy = Lazy(lambda: made.append(1) or ca.MX.sym("x"))
    builder = NlpBuilder([Variable("k", 1.0, 10.0)])
    builder.constrain(lazy, 0.0, 1.0)
    assert builder.expression(lazy) is lazy.build() and made == [1]
