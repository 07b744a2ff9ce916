"""The derivative-free search (feedtune.tuner.search) scores grouped objective terms as the
NLP does (feedtune.tuner.scenarios): the largest group's weighted sum, so that a robust
pulse-generator spec with ``objective: worst_case`` minimises its worst scenario; one
group is the plain weighted sum, as before. Its initial population needs no
``scipy.stats`` (issue 15: Tian's first tuning in a process)."""

from __future__ import annotations

import subprocess
import sys
import textwrap

from feedtune.tuner.search import SearchProblem
from feedtune.tuner.types import Settings, Term, Variable


class _Loop:
    """A stand-in exact-only loop: stable, the tunable x in its ``x``."""

    exact_only = True

    def __init__(self, x: float):
        self.x = x

    def stability(self) -> dict:
        return {"stable": True}


def _problem(terms: list[Term]) -> SearchProblem:
    return SearchProblem([Variable("x", 0.1, 10.0, 1.0)], {}, lambda v: _Loop(v["x"]), terms,
                         [], {}, Settings(multistart=1, max_iter=3))


def test_two_groups_score_the_larger_weighted_sum():
    terms = [Term("a", lambda loop: loop.x, 2.0, group=0),
             Term("a", lambda loop: 10.0 - loop.x, 1.0, group=1)]
    _, objective, _, _ = _problem(terms).measure({"x": 3.0})
    assert objective == max(2.0 * 3.0, 10.0 - 3.0)


def test_one_group_is_the_weighted_sum():
    terms = [Term("a", lambda loop: loop.x, 2.0), Term("b", lambda loop: 1.5, -1.0)]
    _, objective, _, _ = _problem(terms).measure({"x": 3.0})
    assert objective == 2.0 * 3.0 - 1.5


def test_a_search_over_three_tunables_does_not_import_scipy_stats():
    """Differential evolution's Sobol population imported ``scipy.stats`` (0.25–0.5 s, a
    quarter of Tian's first tuning in a fresh process); its Latin hypercube does not. Three
    tunables, as Tian's example (Sobol was used from two up)."""
    code = textwrap.dedent("""
        import sys
        from feedtune.tuner.search import SearchProblem
        from feedtune.tuner.types import Settings, Term, Variable

        class Loop:
            exact_only = True
            def __init__(self, values):
                self.values = values
            def stability(self):
                return {"stable": True}

        problem = SearchProblem([Variable(n, 0.1, 10.0, 1.0) for n in "abc"], {}, Loop,
                                [Term("sum", lambda loop: sum(loop.values.values()))], [],
                                {}, Settings(multistart=1, max_iter=2))
        assert problem.solve().success
        print("scipy.optimize" in sys.modules, "scipy.stats" in sys.modules)
        """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.split() == ["True", "False"]
