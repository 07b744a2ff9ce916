"""The batch's verdicts and CI formats, formula by formula."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from types import SimpleNamespace

import pytest

from feedtune.batch.job import summary_fields
from feedtune.batch.reports import compare, github_annotations, judge, junit_xml, row_ok
from feedtune.validate import warning_lines


def row(**fields) -> dict:
    base = {"id": "x", "input": "specs/x.json", "path": "specs/x.json", "line": None,
            "status": "optimal", "success": True, "constraints_satisfied": True,
            "objective": 1.0, "tuned": {}, "message": "fine", "errors": [], "time": 0.1}
    return {**base, **fields}


def judged(**fields) -> dict:
    """A row as the runner leaves it: ``ok``, ``reason`` and ``message`` set."""
    judged_row = row(**fields)
    judge(judged_row)
    return judged_row


#: a validation block whose radial-error gap exceeds its tolerance (extra keys, as a newer
#: validator may add, must not matter)
GAP = {"metric": "radial_error", "options": {"radius": 0.005, "feed": 0.05},
       "reported": 1.2e-15, "validated": 3.4e-15, "gap": 2.2e-15, "tolerance": 5e-10,
       "ok": False, "scale": 5e-6, "unit": "m"}
FAILED_BLOCK = {"covered": True, "ok": False, "entries": [
    GAP, {**GAP, "metric": "damping_ratio", "options": {}, "ok": True}]}


def validated_result(block: dict) -> SimpleNamespace:
    """The fields of a solved TuneResult that the summary row reads."""
    return SimpleNamespace(status="optimal", success=True, constraints=[], objective=2.0,
                           tuned={}, message="start 1 of 8 gave the best feasible optimum",
                           validation=block, optimum=None, warnings=[])


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
    bad = judged(id="a,b", path="dir/a:b,c.json", line=7, status="invalid", success=False,
                 message="50% off\nsecond line")
    good = judged()
    (line,) = github_annotations([bad, good])
    assert line == ("::error file=dir/a%3Ab%2Cc.json,line=7,title=feedtune%3A a%2Cb invalid::"
                    "50%25 off%0Asecond line")


@pytest.mark.parametrize("fields, reason, says", [
    ({"status": "invalid", "success": False, "message": "/plant/blu: must be > 0"},
     "invalid", "/plant/blu: must be > 0"),
    ({"status": "infeasible", "success": False, "message": "violated: damping_ratio"},
     "infeasible", "violated: damping_ratio"),
    ({"status": "iteration_limit", "success": False}, "iteration_limit", "fine"),
    ({"status": "time_limit", "success": False}, "time_limit", "fine"),
    ({"status": "timeout", "success": False}, "timeout", "fine"),
    ({"status": "worker_died", "success": False}, "worker_died", "fine"),
    ({"status": "error", "success": False}, "error", "fine"),
    ({"status": "not_run", "success": False}, "not_run", "fine"),
    ({"success": False}, "unsuccessful", "not a feasible, stable optimum"),
    ({"constraints_satisfied": False}, "constraint_violated", "a constraint is violated"),
    ({"validation_ok": False}, "validation", "re-simulation"),
    ({"baseline": {"verdict": "worse", "objective": 0.5, "rtol": 1e-6}},
     "worse_than_baseline", "objective 1 is worse than the baseline's 0.5"),
])
def test_a_failing_row_has_a_reason_and_a_message_saying_why(fields, reason, says):
    failed = judged(**fields)
    assert failed["ok"] is False and failed["reason"] == reason
    assert says in failed["message"]
    assert judged()["reason"] is None and judged()["message"] == "fine"


def test_a_validation_failure_names_metric_values_gap_and_tolerance_as_tune_does():
    failed = row(**summary_fields(validated_result(FAILED_BLOCK)))
    judge(failed)
    assert failed["ok"] is False and failed["reason"] == "validation"
    tune_says = [line.removeprefix("warning: ") for line in warning_lines(FAILED_BLOCK)]
    assert failed["message"] == "; ".join(tune_says) and len(tune_says) == 1
    for part in ("validation: radial_error(radius=0.005,feed=0.05) reported 1.2e-15",
                 "re-simulated 3.4e-15", "2.2e-15", "tolerance 5e-10"):
        assert part in failed["message"]
    assert "damping_ratio" not in failed["message"]  # within its tolerance
    (annotation,) = github_annotations([failed])
    assert annotation.endswith("title=feedtune%3A x validation::" + failed["message"])
    case = ET.fromstring(junit_xml([failed], 1.0)).find("testsuite/testcase")
    assert case.find("failure").get("type") == "validation"
    assert case.find("failure").get("message") == failed["message"]


def test_a_row_within_every_tolerance_lists_no_validation_failures():
    block = {**FAILED_BLOCK, "ok": True, "entries": [{**GAP, "ok": True}]}
    passed = row(**summary_fields(validated_result(block)))
    judge(passed)
    assert passed["ok"] and passed["validation_failures"] == []
    assert passed["message"] == "start 1 of 8 gave the best feasible optimum"


def test_junit_names_file_and_line_apart_and_the_reason_as_failure_type():
    rows = [judged(id="a", input="specs/more.jsonl:3", path="specs/more.jsonl", line=3,
                   status="infeasible", success=False, message="no start satisfied"),
            judged(id="b"),
            judged(id="c", baseline={"verdict": "worse", "objective": 0.5, "rtol": 1e-6})]
    suite = ET.fromstring(junit_xml(rows, 2.0)).find("testsuite")
    cases = {case.get("name"): case for case in suite.iter("testcase")}
    assert cases["a"].get("file") == "specs/more.jsonl" and cases["a"].get("line") == "3"
    assert cases["b"].get("file") == "specs/x.json" and cases["b"].get("line") is None
    assert cases["a"].find("failure").get("type") == "infeasible"
    assert cases["c"].find("failure").get("type") == "worse_than_baseline"
    assert cases["b"].find("failure") is None and suite.get("failures") == "2"
    assert json.loads(cases["a"].find("failure").text)["input"] == "specs/more.jsonl:3"


def test_notes_are_annotated_as_warnings_and_fail_nothing():
    r = judged(notes=["optimum not unique: the objective does not decide position_gain"])
    assert r["ok"] is True
    (line,) = github_annotations([r])
    assert line.startswith("::warning file=specs/x.json,title=feedtune%3A x note::optimum not unique")
    case = ET.fromstring(junit_xml([r], 1.0)).find(".//testcase")
    assert case.find("failure") is None
    assert "optimum not unique" in case.find("system-out").text


def test_summary_fields_carry_uniqueness_and_plausibility():
    optimum = SimpleNamespace(unique=False, flat=["position_gain"], spread={"sampling_period": 0})
    result = SimpleNamespace(status="optimal", success=True, constraints=[], objective=0.0,
                             tuned={}, message="m", validation={"ok": True}, optimum=optimum,
                             warnings=["/plant/blu: 1 m is far outside"])
    fields = summary_fields(result)
    assert fields["optimum_unique"] is False
    assert fields["notes"] == ["optimum not unique: the objective does not decide "
                               "position_gain, sampling_period",
                               "implausible: /plant/blu: 1 m is far outside"]


def test_the_command_pins_blas_to_one_thread_unless_the_user_chose():
    from feedtune.__main__ import BLAS_THREADS, pin_blas_threads

    environ = {"MKL_NUM_THREADS": "4", "PATH": "/bin"}
    pin_blas_threads(environ)
    assert environ == {"MKL_NUM_THREADS": "4", "PATH": "/bin",
                       **{name: "1" for name in BLAS_THREADS if name != "MKL_NUM_THREADS"}}
