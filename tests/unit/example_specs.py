"""Bundled example specs for the solver- and structure-reuse tests, results compared
without their timings, and problems built without IPOPT's solver (a tuning run up to its
solve)."""

import contextlib
import json
from pathlib import Path

import pytest

from feedtune.problem import tune
from feedtune.schema.spec import parse_spec
from feedtune.tuner import cache, nlp

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
TIMING = ("solve_time", "build_time", "evaluation_time")
#: examples whose one free gain IPOPT would not solve unless asked to
ONE_GAIN = ("koren-1979-min-iae-radius.json", "koren-1979-sampled-data.json",
            "koren-1979-reference-pulse.json")


def load_example(name: str) -> dict:
    """The bundled spec ``name`` as a dict; Koren's one-gain examples with an IPOPT option,
    so that they build a solver (one free gain goes to the scalar search, and one free gain
    with one |e| to the root search, which build none; the option given is IPOPT's default
    here: same results)."""
    data = json.loads((EXAMPLES / name).read_text(encoding="utf-8"))
    if name in ONE_GAIN:
        data["solver"]["ipopt_options"] = {"hessian_approximation": "exact"}
    return data


def without_timing(result) -> dict:
    """The result as JSON data without its wall-clock times."""
    data = result.model_dump(mode="json")
    for key in TIMING:
        data["solver"].pop(key)
    for start in data["solver"]["starts"]:
        start.pop("solve_time")
    return data


class _SolveReached(BaseException):
    """Stops :func:`built` where the tuning's solve would start (``tune`` turns every
    ``Exception`` into a result)."""


@contextlib.contextmanager
def problems_built_only():
    """Inside, :func:`built` runs ``tune`` up to its solve: the Problem is built as ``tune``
    builds it (the structure cache's look-up and store, the Functions, the solver cache's
    key from their serialized graphs, its hit or miss), but IPOPT's solver is a stand-in
    and nothing is solved. For tests whose subject is the build (keys, graphs, cache
    counters), not the solver or the result: building IPOPT's solver (≈ 0.4 s on the
    minimum-IAE example, SX expansion of its step integrals) and solving were most of their
    CPU. Yields the list of the Problems' structure keys and the number of solvers the
    cache asked for; the caches are cleared on leaving (they hold the stand-ins)."""
    keys: list = []
    made = [0]
    init = nlp.Problem.__init__

    def spy(self, *args, **kwargs):
        keys.append(kwargs.get("structure_key"))
        init(self, *args, **kwargs)

    def stand_in(nlp_function, options, expand):
        made[0] += 1
        return None

    def stop(self, progress=None):
        raise _SolveReached

    try:
        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(nlp.Problem, "__init__", spy)
            patch.setattr(nlp.Problem, "solve", stop)
            patch.setattr(cache, "make_solver", stand_in)
            yield keys, made
    finally:
        cache.clear_solver_cache()


def built(data: dict) -> None:
    """``tune(data)`` up to its first solve, inside :func:`problems_built_only` (every spec
    these tests build this way builds one Problem: no longer step-response horizon)."""
    try:
        tune(parse_spec(data))
    except _SolveReached:
        return
    raise AssertionError(f"{data['name']}: tune returned before it solved anything")
