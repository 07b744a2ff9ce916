"""integer_ratio: q = T/Δt_p made whole by solving relaxed, then at ⌊q⌋ and ⌈q⌉."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from feedtune.problem import tune
from feedtune.schema.spec import SpecError, parse_spec

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def _example(name):
    return json.loads((EXAMPLES / f"{name}.json").read_text())


def test_throughput_rounds_down_when_up_is_infeasible():
    """The relaxed largest T is 26.31 ms (q = 13.15 at Δt_p = 2 ms); q = 14 (T = 28 ms)
    breaks the roughness bound, q = 13 gives T = 26 ms exactly."""
    spec = _example("sato-throughput")
    spec["plant"]["integer_ratio"] = True
    result = tune(parse_spec(spec))
    assert result.success
    assert result.tuned["reference_interval"].value == pytest.approx(0.026, rel=1e-9)
    assert result.metrics["interpolation_ratio"].value == pytest.approx(13, abs=1e-9)
    assert "relaxed q = 13.15" in result.message and "kept q = 13" in result.message
    assert "q = 14: infeasible" in result.message
    assert result.constraints[-1].metric == "interpolation_ratio"


def test_finish_keeps_the_better_of_floor_and_ceil():
    """T ≥ 11 ms: relaxed q = 5.5 (T = 11 ms, Δt_p = 2 ms); both 5 and 6 are feasible,
    the smoother (lower Δm) is kept, and it is no better than the relaxed optimum."""
    spec = _example("sato-finish")
    spec["plant"]["integer_ratio"] = True
    spec["tunables"]["reference_interval"]["min"] = 0.011
    result = tune(parse_spec(spec))
    assert result.success
    q = result.metrics["interpolation_ratio"].value
    assert q == pytest.approx(round(q), abs=1e-9) and round(q) in (5, 6)
    assert "q = 5: optimal" in result.message and "q = 6: optimal" in result.message
    relaxed = tune(parse_spec(_example("sato-finish") | {
        "tunables": spec["tunables"]}))
    assert result.objective >= relaxed.objective * (1 - 1e-9)


def test_integer_ratio_needs_an_interpolator():
    spec = _example("sato-throughput")
    spec["plant"].update(integer_ratio=True, interpolation="none")
    spec["tunables"].pop("reference_interval")
    spec["objective"] = [{"metric": "velocity_constant", "goal": "maximize"}]
    spec["constraints"] = []
    with pytest.raises(SpecError, match="integer_ratio"):
        parse_spec(spec)
