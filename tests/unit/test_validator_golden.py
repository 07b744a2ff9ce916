"""The validation block of every bundled example, as the validator wrote it before its
metric selection became a table (issue 16): the same entries, in the same order, with the
same values, gaps, tolerances and verdicts.

tests/data/validation-golden.json holds, per example, what the validator reads of a
result of ``feedtune tune examples/<name>.json`` (plant spec, tuned values, metrics,
stability) and the block the validator gave it at commit f6bb14e. The validator's
arithmetic did not change, only how it picks a measurement, so floats are compared to
1e-12 relative (rounding of a reordered sum at most; measured: identical bits). Since the
linear drive's frequency responses are solved by elimination along the loop instead of
a 9 × 9 LU (issue 15), its values differ by rounding (≤ 2.4e-15 relative, measured); a
gap (reported − validated, both ≈ the same number) is therefore compared on the scale
of the value it is the difference of: within 1e-12 of |validated|, the precision the
validated value itself is held to, not relative to the gap (≈ 0). Since the software
servo's step integrals are exact (issue 15, branch h-bval2: per sample and in closed form
instead of a trapezoid on a dense grid), their 30 entries of the Koren examples hold the
exact values: each moved by 4e-10 … 4.3e-7 relative, towards the tuner's exact value and a
Richardson-extrapolated dense reference (now within 4e-12 of both; benchmarks/README.md).
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
            if key == "gap" and isinstance(old[key], float) and isinstance(
                    old.get("validated"), float) and math.isfinite(old["validated"]):
                assert abs(new[key] - old[key]) <= REL * abs(old["validated"]), \
                    f"{where}/gap: {new[key]!r} != {old[key]!r}"
                continue
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


def test_the_golden_comparison_sees_a_changed_gap():
    """A gap is held on its value's scale: one moved by 1e-9 of |validated| fails."""
    case = GOLDEN["user-defined-drive"]
    block = json.loads(json.dumps(validate_result(case["result"])))
    entry = next(e for e in block["entries"] if isinstance(e["gap"], float)
                 and isinstance(e["validated"], float) and e["validated"] != 0)
    entry["gap"] += 1e-9 * abs(entry["validated"])
    with pytest.raises(AssertionError, match="gap"):
        _same(block, case["validation"], "tampered")
