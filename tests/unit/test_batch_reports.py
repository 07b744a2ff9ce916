"""The batch's verdicts and CI formats, formula by formula."""

from __future__ import annotations

import pytest

from feedtune.batch.reports import compare, github_annotations, row_ok


def row(**fields) -> dict:
    base = {"id": "x", "input": "specs/x.json", "path": "specs/x.json", "line": None,
            "status": "optimal", "success": True, "constraints_satisfied": True,
            "objective": 1.0, "tuned": {}, "message": "fine", "errors": [], "time": 0.1}
    return {**base, **fields}


@pytest.mark.parametrize("now, before, verdict", [
    (1.0, 1.0, "same"),
    (1.0 + 0.5e-6, 1.0, "same"),  # within rtol 1e-6
    (1.0 + 2e-6, 1.0, "worse"),
    (1.0 - 2e-6, 1.0, "better"),
    (-0.999, -1.0, "worse"),  # maximised terms count negatively: −bandwidth rose
    (None, 1.0, "worse"),  # solved before, not now
])
def test_baseline_verdicts(now, before, verdict):
    block = compare(row(objective=now), {"objective": before, "ok": True}, rtol=1e-6)
    assert block["verdict"] == verdict and block["objective"] == before


def test_no_earlier_row_or_objective_is_not_a_regression():
    assert compare(row(), None)["verdict"] == "new"
    assert compare(row(), {"objective": None, "ok": False})["verdict"] == "unsolved_before"
    assert row_ok({**row(), "baseline": compare(row(), None)})


@pytest.mark.parametrize("fields, ok", [
    ({}, True),
    ({"status": "acceptable"}, True),
    ({"status": "infeasible", "success": False}, False),
    ({"constraints_satisfied": False}, False),
    ({"success": False}, False),  # e.g. solved but unstable
    ({"status": "invalid", "success": False, "constraints_satisfied": None}, False),
    ({"baseline": {"verdict": "worse", "objective": 0.5, "rtol": 1e-6}}, False),
])
def test_a_row_is_ok_only_when_solved_feasible_and_not_worse(fields, ok):
    assert row_ok(row(**fields)) is ok


def test_github_annotations_escape_what_would_end_the_command():
    bad = row(id="a,b", path="dir/a:b,c.json", line=7, status="invalid", success=False,
              message="50% off\nsecond line", ok=False)
    good = row(ok=True)
    (line,) = github_annotations([bad, good])
    assert line.startswith("::error file=dir/a%3Ab%2Cc.json,line=7,title=feedtune%3A a%2Cb invalid::")
    assert line.endswith("invalid: 50%25 off%0Asecond line")
