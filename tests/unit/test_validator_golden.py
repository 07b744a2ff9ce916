"""The validation block of every bundled example, as the validator wrote it before its
metric selection became a table (issue 16): the same entries, in the same order, with the
same values, gaps, tolerances and verdicts.

tests/data/validation-golden.json holds, per example, what the validator reads of a
result of ``feedtune tune examples/<name>.json`` (plant spec, tuned values, metrics,
stability) and the block the validator gave it at commit f6bb14e. The validator's
arithmetic did not change, only how it picks a measurement, so floats are compared to
1e-12 relative (rounding of a reordered sum at most; measured: identical bits).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from feedtune.validate import validate_result

GOLDEN = json.loads((Path(__file__).parents[1] / "data" / "validation-golden.json").read_text())

#: relative agreement of every float: the same operations on the same numbers
REL = 1e-12


def _same(new, old, where: str) -> None:
    if isinstance(old, float) or isinstance(new, float):
        assert isinstance(new, (int, float)) and isinstance(old, (int, float)), where
        if math.isinf(old) or math.isnan(old):
            assert new == old or (math.isnan(new) and math.isnan(old)), where
        else:
            assert math.isclose(new, old, rel_tol=REL, abs_tol=0.0) or new == old, \
                f"{where}: {new!r} != {old!r}"
    elif isinstance(old, dict):
        assert isinstance(new, dict) and sorted(new) == sorted(old), \
            f"{where}: keys {sorted(new)} != {sorted(old)}"
        for key in old:
            _same(new[key], old[key], f"{where}/{key}")
    elif isinstance(old, list):
        assert isinstance(new, list) and len(new) == len(old), \
            f"{where}: length {len(new)} != {len(old)}"
        for i, (a, b) in enumerate(zip(new, old)):
            _same(a, b, f"{where}/{i}")
    else:
        assert new == old, f"{where}: {new!r} != {old!r}"


@pytest.mark.parametrize("example", sorted(GOLDEN))
def test_validation_block_is_unchanged(example):
    case = GOLDEN[example]
    block = json.loads(json.dumps(validate_result(case["result"])))
    assert case["validation"]["entries"], "a golden block without entries checks nothing"
    _same(block, case["validation"], example)


def test_the_golden_comparison_sees_a_changed_entry():
    """The comparison itself can fail: one validated value moved by 1e-9 relative."""
    case = GOLDEN["koren-1979-sampled-data"]
    block = json.loads(json.dumps(validate_result(case["result"])))
    entry = next(e for e in block["entries"] if isinstance(e["validated"], float))
    entry["validated"] *= 1 + 1e-9
    with pytest.raises(AssertionError):
        _same(block, case["validation"], "tampered")
