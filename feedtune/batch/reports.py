"""What a batch tells people and CI: the summary file, a table, JUnit XML, GitHub
annotations, and the comparison with a baseline batch."""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET
from pathlib import Path

from feedtune.tuner.nlp import SOLVED

#: objective worse than the baseline's by more than this, relative, fails the spec
BASELINE_RTOL = 1e-6


def row_ok(row: dict) -> bool:
    """Solved, stable and feasible (``success``), every constraint met, the independent
    re-simulation within its tolerances (``validation_ok`` not False), not worse than the
    baseline."""
    return (row["status"] in SOLVED and bool(row.get("success"))
            and row.get("constraints_satisfied") is not False
            and row.get("validation_ok") is not False
            and (row.get("baseline") or {}).get("verdict") != "worse")


def why_failed(row: dict) -> str:
    """One sentence for people on why ``row`` is not ok."""
    baseline = row.get("baseline") or {}
    if baseline.get("verdict") == "worse" and row["status"] in SOLVED and row.get("success"):
        return (f"objective {_g(row['objective'])} is worse than the baseline's "
                f"{_g(baseline['objective'])} (relative tolerance {baseline['rtol']:g})")
    if row["status"] in SOLVED and row.get("constraints_satisfied") is False:
        return f"a constraint is violated: {row['message']}"
    if row["status"] in SOLVED and row.get("success") and row.get("validation_ok") is False:
        return ("the independent re-simulation (feedtune.validate) differs from the reported "
                "metrics beyond tolerance; see the result's validation block")
    return f"{row['status']}: {row['message']}"


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
            verdict = "ok" if r["ok"] else "FAIL: " + why_failed(r)
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
    """JUnit XML: one test case per spec, a failure for each spec not ok."""
    failures = sum(1 for r in rows if not r["ok"])
    suites = ET.Element("testsuites", name="feedtune batch", tests=str(len(rows)),
                        failures=str(failures), errors="0", time=f"{wall:.3f}")
    suite = ET.SubElement(suites, "testsuite", name="feedtune batch", tests=str(len(rows)),
                          failures=str(failures), errors="0", skipped="0", time=f"{wall:.3f}")
    for r in rows:
        case = ET.SubElement(suite, "testcase", classname="feedtune.batch", name=r["id"],
                             file=r["input"], time=f"{r['time']:.3f}")
        if not r["ok"]:
            failure = ET.SubElement(case, "failure", type=r["status"], message=why_failed(r))
            failure.text = json.dumps({k: r.get(k) for k in
                                       ("input", "status", "message", "errors", "objective",
                                        "baseline")}, indent=2)
        else:
            out = ET.SubElement(case, "system-out")
            out.text = f"objective {_g(r['objective'])}; tuned " + json.dumps(r["tuned"])
    ET.indent(suites)
    return ET.tostring(suites, encoding="utf-8", xml_declaration=True) + b"\n"


def _escape_data(text: str) -> str:
    return text.replace("%", "%25").replace("\r", "%0D").replace("\n", "%0A")


def _escape_property(text: str) -> str:
    return _escape_data(text).replace(":", "%3A").replace(",", "%2C")


def github_annotations(rows: list[dict]) -> list[str]:
    """GitHub Actions ``::error`` workflow commands, one per spec not ok, naming its file."""
    lines = []
    for r in rows:
        if r["ok"]:
            continue
        location = f"file={_escape_property(r['path'])}"
        if r.get("line"):
            location += f",line={r['line']}"
        title = _escape_property(f"feedtune: {r['id']} {r['status']}")
        lines.append(f"::error {location},title={title}::{_escape_data(why_failed(r))}")
    return lines
