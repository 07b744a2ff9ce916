"""Spec checks that need more than pydantic: IPOPT's own option table."""

import json
from pathlib import Path

import pytest

from feedtune.spec import SpecError, parse_spec

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "koren-1979-sampled-data.json"


@pytest.mark.parametrize("options, pointer, reason", [
    ({"bogus_option": 3}, "/solver/ipopt_options/bogus_option", "No such IPOPT option"),
    ({"max_iter": "abc"}, "/solver/ipopt_options/max_iter", "type mismatch"),
])
def test_ipopt_options_are_checked_by_ipopt_before_solving(options, pointer, reason):
    spec = json.loads(EXAMPLE.read_text())
    spec["solver"]["ipopt_options"] = options
    with pytest.raises(SpecError) as info:
        parse_spec(spec)
    assert info.value.errors[0][0] == pointer
    assert reason in info.value.errors[0][1]


def test_valid_ipopt_options_pass():
    spec = json.loads(EXAMPLE.read_text())
    spec["solver"]["ipopt_options"] = {"max_iter": 50, "mu_strategy": "adaptive"}
    assert parse_spec(spec).solver.ipopt_options["max_iter"] == 50
