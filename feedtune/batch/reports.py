"""What a batch tells people and CI: the summary file, a table, JUnit XML, GitHub
annotations, and the comparison with a baseline batch.

A spec that is not ok has a ``reason``, which is also its JUnit failure ``type`` and its
GitHub annotation's title: its status when that is not a solved one (``invalid``,
``infeasible``, ``iteration_limit``, ``time_limit``, ``error``, ``timeout``,
``worker_died``, ``not_run``), else the first of ``unsuccessful``,
``constraint_violated``, ``validation``, ``worse_than_baseline`` that applies.
"""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET
from pathlib import Path

from feedtune.schema.status import SOLVED

#: objective worse than the baseline's by more than this, relative, fails the spec
BASELINE_RTOL = 1e-6
#: reasons of a solved spec that is still not ok (see the module docstring)
UNSUCCESSFUL, CONSTRAINT_VIOLATED, VALIDATION, WORSE_THAN_BASELINE = (
    "unsuccessful", "constraint_violated", "validation", "worse_than_baseline")


def failure(row: dict) -> tuple[str, str] | None:
    """``(reason, message)`` for a row that is not ok, None for one that is.

    Not ok: not solved (the reason is the status, the message the solver's or the job's),
    solved without ``success`` (not a feasible, stable optimum), a constraint violated, the
    independent re-simulation beyond tolerance (``validation_ok`` False; the message names
    each metric, both values, the gap and the tolerance, as ``feedtune tune`` warns), or an
    objective worse than the baseline's.
    """
    if row["status"] not in SOLVED:
        return row["status"], row["message"]
    if not row.get("success"):
        return UNSUCCESSFUL, f"solved, but not a feasible, stable optimum: {row['message']}"
    if row.get("constraints_satisfied") is False:
        return CONSTRAINT_VIOLATED, f"a constraint is violated: {row['message']}"
    if row.get("validation_ok") is False:
        return VALIDATION, ("; ".join(row.get("validation_failures") or ())
                            or "the independent re-simulation (feedtune.validate) differs from "
                               "the reported metrics beyond tolerance; see the result's "
                               "validation block")
    baseline = row.get("baseline") or {}
    if baseline.get("verdict") == "worse":
        return WORSE_THAN_BASELINE, (
            f"objective {_g(row['objective'])} is worse than the baseline's "
            f"{_g(baseline['objective'])} (relative tolerance {baseline['rtol']:g})")
    return None


def row_ok(row: dict) -> bool:
    """Solved, stable and feasible (``success``), every constraint met, the independent
    re-simulation within its tolerances (``validation_ok`` not False), not worse than the
    baseline: no :func:`failure`."""
    return failure(row) is None


def judge(row: dict) -> None:
    """Set ``ok`` and ``reason`` (None when ok) and, for a row not ok, its ``message`` to
    :func:`failure`'s."""
    found = failure(row)
    row["ok"] = found is None
    row["reason"] = None
    if found is not None:
        row["reason"], row["message"] = found


def _g(value) -> str:
    return "n/a" if value is None else f"{value:.6g}"


# -- baseline ----------------------------------------------------------------------------

class BaselineError(ValueError):
    """The baseline directory cannot be used (exit status 2)."""


def load_baseline(directory: Path) -> dict[str, dict]:
    """Rows of an earlier batch's ``summary.json``, by result id."""
    path = directory / "summary.json"
    try:
        summary = json.loads(path.read_text(encoding="utf-8"))
        return {row["id"]: row for row in summary["rows"]}
    except FileNotFoundError:
        raise BaselineError(f"{path}: no such file (give the --out directory of an earlier batch)") from None
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise BaselineError(f"{path}: not a feedtune batch summary ({exc})") from None


def compare(row: dict, base: dict | None, rtol: float = BASELINE_RTOL) -> dict:
    """The baseline block of ``row``: the earlier objective and a verdict.

    Objectives are minimised (maximised terms count negatively), so worse means larger.
    Verdicts: ``new`` (no earlier row), ``unsolved_before`` (no earlier objective),
    ``lost`` (solved before, no objective now: counted worse), ``worse``, ``better``,
    ``same`` (within ``rtol``·|earlier|).
    """
    block = {"objective": None, "verdict": "new", "rtol": rtol}
    if base is None:
        return block
    before, now = base.get("objective"), row.get("objective")
    block["objective"] = before
    if before is None or not base.get("ok", True):
        block["verdict"] = "unsolved_before"
    elif now is None:
        block["verdict"] = "worse"
        block["lost"] = True
    else:
        margin = rtol * max(abs(before), 1e-300)
        block["verdict"] = ("worse" if now > before + margin else
                            "better" if now < before - margin else "same")
    return block


# -- summary -----------------------------------------------------------------------------

def summary_document(rows: list[dict], header: dict) -> dict:
    counts: dict[str, int] = {}
    for row in rows:
        counts[row["status"]] = counts.get(row["status"], 0) + 1
    return {**header, "specs": len(rows), "ok": sum(1 for r in rows if r["ok"]),
            "failed": sum(1 for r in rows if not r["ok"]), "counts": counts, "rows": rows}


def table(rows: list[dict], limit: int = 100) -> list[str]:
    """The rows as aligned text; beyond ``limit`` rows only those not ok are listed."""
    shown = rows if len(rows) <= limit else [r for r in rows if not r["ok"]]
    lines = []
    if len(shown) < len(rows):
        lines.append(f"({len(rows) - len(shown)} ok specs not listed; see summary.json)")
    if shown:
        name_w = min(40, max(len("spec"), *(len(r["id"]) for r in shown)))
        status_w = max(len("status"), *(len(r["status"]) for r in shown))
        lines.append(f"{'spec':<{name_w}}  {'status':<{status_w}}  {'objective':>12}  "
                     f"{'time [s]':>8}  verdict")
        for r in shown:
            verdict = "ok" if r["ok"] else f"FAIL: {r['message']}"
            if r.get("notes"):
                verdict += "; " + "; ".join(r["notes"])
            if r.get("resumed"):
                verdict += " (resumed)"
            lines.append(f"{r['id'][:name_w]:<{name_w}}  {r['status']:<{status_w}}  "
                         f"{_g(r['objective']):>12}  {r['time']:>8.3f}  {verdict}")
    return lines


def totals_line(document: dict, wall: float) -> str:
    counts = ", ".join(f"{n} {status}" for status, n in sorted(document["counts"].items()))
    resumed = sum(1 for r in document["rows"] if r.get("resumed"))
    rate = document["specs"] / wall if wall > 0 else math.inf
    return (f"{document['specs']} specs: {document['ok']} ok, {document['failed']} failed "
            f"({counts}); {resumed} resumed; {wall:.1f} s wall, {rate:.3g} specs/s")


# -- CI formats --------------------------------------------------------------------------

def junit_xml(rows: list[dict], wall: float) -> bytes:
    """JUnit XML: one test case per spec (``file`` its path, ``line`` its JSON Lines line),
    a failure for each spec not ok, its ``type`` the row's ``reason``."""
    failures = sum(1 for r in rows if not r["ok"])
    suites = ET.Element("testsuites", name="feedtune batch", tests=str(len(rows)),
                        failures=str(failures), errors="0", time=f"{wall:.3f}")
    suite = ET.SubElement(suites, "testsuite", name="feedtune batch", tests=str(len(rows)),
                          failures=str(failures), errors="0", skipped="0", time=f"{wall:.3f}")
    for r in rows:
        case = ET.SubElement(suite, "testcase", classname="feedtune.batch", name=r["id"],
                             file=r["path"], time=f"{r['time']:.3f}")
        if r.get("line"):
            case.set("line", str(r["line"]))
        if not r["ok"]:
            failed = ET.SubElement(case, "failure", type=r["reason"], message=r["message"])
            failed.text = json.dumps({k: r.get(k) for k in
                                      ("input", "status", "reason", "message", "errors",
                                       "validation_failures", "notes", "objective", "baseline")},
                                     indent=2)
        else:
            out = ET.SubElement(case, "system-out")
            out.text = (f"objective {_g(r['objective'])}; tuned " + json.dumps(r["tuned"])
                        + "".join(f"\n{note}" for note in r.get("notes") or ()))
    ET.indent(suites)
    return ET.tostring(suites, encoding="utf-8", xml_declaration=True) + b"\n"


def _escape_data(text: str) -> str:
    return text.replace("%", "%25").replace("\r", "%0D").replace("\n", "%0A")


def _escape_property(text: str) -> str:
    return _escape_data(text).replace(":", "%3A").replace(",", "%2C")


def github_annotations(rows: list[dict]) -> list[str]:
    """GitHub Actions ``::error`` workflow commands, one per spec not ok, naming its file, its
    line (JSON Lines), its ``reason`` in the title and its ``message``; and a ``::warning``
    per note (a non-unique optimum, an implausible design), which fails nothing."""
    lines = []
    for r in rows:
        location = f"file={_escape_property(r['path'])}"
        if r.get("line"):
            location += f",line={r['line']}"
        if not r["ok"]:
            title = _escape_property(f"feedtune: {r['id']} {r['reason']}")
            lines.append(f"::error {location},title={title}::{_escape_data(r['message'])}")
        for note in r.get("notes") or ():
            title = _escape_property(f"feedtune: {r['id']} note")
            lines.append(f"::warning {location},title={title}::{_escape_data(note)}")
    return lines
