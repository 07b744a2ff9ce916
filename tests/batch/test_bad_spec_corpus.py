"""A corpus of bad specs through one real ``feedtune batch`` run.

The issue asks: "A corpus of bad specs — empty file, truncated JSON, duplicate keys,
NaN/Infinity, wrong types, unknown keys, negative or zero time constants, min > max, a
10 MB file, deeply nested JSON, non-UTF-8 bytes — each gives a clear error naming the
field, no traceback, and the batch goes on."

Every bad spec below is the valid example ``koren-1979-sampled-data`` with exactly one
defect (and its own ``name``, so its result stem is its case id). One valid spec sits among
them, and one JSON Lines file holds a valid line, a blank line, a bad line and a truncated
line. The whole corpus goes through ONE ``feedtune batch DIR --out OUT --junit X --format
github`` (a module-scoped fixture; the real entry point, in the test process); each defect is then its own test id:

- its summary row is ``invalid``, not ok, with no result file;
- ``errors`` holds exactly the expected JSON pointer (the field) — ``""`` for file-level
  defects (empty, truncated, non-UTF-8, 10 MB, nesting, not an object) — and the message
  says what is wrong;
- a JUnit ``<failure>`` and exactly one ``::error`` annotation naming its file (and
  ``line=N`` for a JSON Lines row);
- no traceback anywhere, the valid specs are solved with a result file, exit status 1.

NaN/Infinity and duplicate keys are named at the field where they occur, and a value of
the wrong JSON type (a string for a number, ``true`` for a count) is an error, not
coerced (the README: "Specs are strict: unknown keys, NaN/Infinity, duplicate keys and
wrong types are errors naming the field").
"""

from __future__ import annotations

import json
import subprocess
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import pytest

from feedtune_cli import run_cli

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "examples" / "koren-1979-sampled-data.json"
VALID = "valid"  # the one valid .json spec of the corpus
TEN_MB = 10 * 1024 * 1024
DEEP = 100_000  # levels of nesting: past any recursion limit


@dataclass(frozen=True)
class Case:
    """One bad spec: its file content and what the batch must say about it.

    ``pointer``: the JSON pointer its single error must carry (``""`` for a file-level
    defect). ``says``: text the message must hold.
    """

    id: str
    data: bytes
    pointer: str
    says: str


def _base(name: str) -> dict:
    spec = json.loads(EXAMPLE.read_text())
    spec["name"] = name
    return spec


def _text(spec: dict) -> str:
    return json.dumps(spec, indent=2)


def _edit(name: str, edit) -> bytes:
    """The example named ``name`` with ``edit(spec)`` applied, as JSON bytes."""
    spec = _base(name)
    edit(spec)
    return _text(spec).encode()


def _replace(name: str, old: str, new: str) -> bytes:
    """The example named ``name`` as text with ``old`` (occurring once) replaced by ``new``."""
    text = _text(_base(name))
    assert text.count(old) == 1, old
    return text.replace(old, new).encode()


def _set(path: tuple, value):
    def edit(spec):
        node = spec
        for key in path[:-1]:
            node = node[key]
        node[path[-1]] = value
    return edit


def _deep_description(name: str, depth: int) -> bytes:
    spec = _base(name)
    spec["description"] = "@@DEEP@@"
    return _text(spec).replace('"@@DEEP@@"', "[" * depth + "]" * depth).encode()


def corpus() -> list[Case]:
    text = _text(_base("truncated")).encode()
    return [
        # -- file-level: pointer "" ----------------------------------------------------
        Case("empty", b"", "", "spec is empty"),
        Case("whitespace-only", b" \n\t\n", "", "spec is empty"),
        Case("truncated", text[: len(text) // 2], "", "invalid JSON at line"),
        Case("non-utf8", _replace("non-utf8", "Koren 1979 design", "Koren @@ design")
             .replace(b"@@", b"\xff\xfe"), "", "not UTF-8"),
        Case("latin1", _replace("latin1", "Koren 1979 design", "K\u00f6ren 1979 design")
             .replace("K\u00f6ren".encode(), "K\u00f6ren".encode("latin-1")), "", "not UTF-8"),
        Case("ten-mb", _edit("ten-mb", _set(("description",), "x" * TEN_MB)), "",
             "larger than the limit"),
        Case("nested-40", _deep_description("nested-40", 40), "", "nested deeper than"),
        Case("nested-100000", _deep_description("nested-100000", DEEP), "",
             "nested deeper than"),
        Case("not-an-object", b"[" + _text(_base("not-an-object")).encode() + b"]", "",
             "a spec is a JSON object"),
        # -- strict JSON ----------------------------------------------------------------
        Case("duplicate-key", _replace("duplicate-key", '"time_constant": 0.02',
                                       '"time_constant": 0.02,\n    "time_constant": 0.03'),
             "/plant/time_constant", "duplicate key 'time_constant'"),
        Case("nan", _replace("nan", '"time_constant": 0.02', '"time_constant": NaN'),
             "/plant/time_constant", "NaN is not valid JSON"),
        Case("infinity", _replace("infinity", '"max_velocity": 0.04', '"max_velocity": Infinity'),
             "/plant/max_velocity", "Infinity is not valid JSON"),
        Case("minus-infinity", _replace("minus-infinity", '"min": 0.5', '"min": -Infinity'),
             "/constraints/0/min", "-Infinity is not valid JSON"),
        Case("overflow", _replace("overflow", '"time_constant": 0.02', '"time_constant": 1e400'),
             "/plant/time_constant", "finite number"),
        # -- wrong types ----------------------------------------------------------------
        # a list for a bound (a list for a plant number is a robust set of values now)
        Case("type-list-for-number", _edit("type-list-for-number",
                                           _set(("constraints", 0, "min"), [0.5])),
             "/constraints/0/min", "valid number"),
        Case("type-word-for-number", _edit("type-word-for-number",
                                           _set(("plant", "blu"), "five microns")),
             "/plant/blu", "valid number"),
        Case("type-number-for-name", _edit("type-number-for-name", _set(("name",), 5)),
             "/name", "valid string"),
        Case("type-object-for-list", _edit("type-object-for-list", _set(
            ("objective",), {"metric": "radial_error", "radius": 0.008, "feed": 0.04})),
             "/objective", "valid array"),
        Case("type-fraction-for-count", _edit("type-fraction-for-count",
                                              _set(("solver", "multistart"), 8.5)),
             "/solver/multistart", "valid integer"),
        Case("type-string-for-number", _edit("type-string-for-number",
                                             _set(("plant", "time_constant"), "0.02")),
             "/plant/time_constant", "valid number"),
        Case("type-bool-for-count", _edit("type-bool-for-count",
                                          _set(("solver", "multistart"), True)),
             "/solver/multistart", "valid integer"),
        # -- unknown keys ---------------------------------------------------------------
        Case("unknown-top-key", _edit("unknown-top-key", _set(("colour",), "red")),
             "/colour", "not permitted"),
        Case("unknown-plant-key", _edit("unknown-plant-key", _set(("plant", "timeconstant"), 0.02)),
             "/plant/timeconstant", "not permitted"),
        Case("unknown-tunable", _edit("unknown-tunable", _set(
            ("tunables", "velocity_gain"), {"min": 1, "max": 2})),
             "/tunables/velocity_gain", "unknown tunable"),
        Case("unknown-plant-type", _edit("unknown-plant-type", _set(("plant", "type"), "stepper")),
             "/plant", '"stepper"'),
        # -- values out of range ----------------------------------------------------------
        Case("time-constant-zero", _edit("time-constant-zero", _set(("plant", "time_constant"), 0)),
             "/plant/time_constant", "greater than 0"),
        Case("time-constant-negative", _edit("time-constant-negative",
                                             _set(("plant", "time_constant"), -0.02)),
             "/plant/time_constant", "greater than 0"),
        Case("sampling-period-zero", _edit("sampling-period-zero",
                                           _set(("tunables", "sampling_period", "value"), 0)),
             "/tunables/sampling_period/value", "greater than 0"),
        Case("gain-min-above-max", _edit("gain-min-above-max", _set(
            ("tunables", "position_gain"), {"min": 300, "max": 200})),
             "/tunables/position_gain", "min (300.0) is greater than max (200.0)"),
        Case("constraint-min-above-max", _edit("constraint-min-above-max", _set(
            ("constraints", 0), {"metric": "damping_ratio", "min": 0.9, "max": 0.5})),
             "/constraints/0", "min (0.9) is greater than max (0.5)"),
        Case("initial-outside-bounds", _edit("initial-outside-bounds", _set(  # found by tune
            ("tunables", "position_gain"), {"min": 1, "max": 200, "initial": 500})),
             "/tunables/position_gain/initial", "outside [1.0, 200.0]"),
        Case("missing-plant", _edit("missing-plant", lambda s: s.pop("plant")),
             "/plant", "Field required"),
    ]


CASES = corpus()

JSONL = "lines.jsonl"
#: line number → (name, expected pointer, message text); None: the valid line
JSONL_LINES = {1: None, 3: ("jsonl-time-constant-zero", "/plant/time_constant", "greater than 0"),
               4: ("lines-4", "", "invalid JSON")}


def _jsonl() -> bytes:
    valid = json.dumps(_base("jsonl-valid"))
    bad = json.loads(_edit("jsonl-time-constant-zero", _set(("plant", "time_constant"), 0)))
    bad = json.dumps(bad)
    return f"{valid}\n   \n{bad}\n{valid[:-40]}\n".encode()


def _ids(cases):
    return [pytest.param(c, id=c.id) for c in cases]


# -- one batch over the whole corpus ---------------------------------------------------------

@dataclass
class Batch:
    specs: Path
    out: Path
    proc: subprocess.CompletedProcess
    summary: dict
    rows: dict[str, dict]  # by input label (path, or path:line)
    junit: ET.Element
    annotations: list[str]


@pytest.fixture(scope="module")
def batch(tmp_path_factory) -> Batch:
    root = tmp_path_factory.mktemp("corpus")
    specs = root / "specs"
    specs.mkdir()
    for case in CASES:
        (specs / f"{case.id}.json").write_bytes(case.data)
    (specs / f"{VALID}.json").write_text(_text(_base(VALID)))
    (specs / JSONL).write_bytes(_jsonl())
    out, junit = root / "out", root / "junit.xml"
    # through the real entry point in this process (its worker forked from it): what is
    # tested is what the batch writes and prints, not its process; one worker, which goes on
    # after every bad spec (a second only forked again for the same rows: ≈ 0.1 s of CPU)
    proc = run_cli("batch", str(specs), "--out", str(out), "--junit", str(junit),
                   "--format", "github", "-j", "1", cwd=REPO, text=True)
    assert (out / "summary.json").is_file(), proc.stderr
    summary = json.loads((out / "summary.json").read_text())
    return Batch(specs, out, proc, summary, {row["input"]: row for row in summary["rows"]},
                 ET.parse(junit).getroot(),
                 [line for line in proc.stdout.splitlines() if line.startswith("::error ")])


def _path(batch: Batch, case_id: str) -> str:
    return str(batch.specs / f"{case_id}.json")


def _property(text: str) -> str:
    """GitHub workflow-command property escaping."""
    return (text.replace("%", "%25").replace("\r", "%0D").replace("\n", "%0A")
            .replace(":", "%3A").replace(",", "%2C"))


def _annotations(batch: Batch, path: str, line: int | None = None) -> list[str]:
    location = f"file={_property(path)}" + (f",line={line}" if line else "")
    return [a for a in batch.annotations
            if a.startswith(f"::error {location},") or a.startswith(f"::error {location}::")]


def _failures(batch: Batch, path: str, line: int | None = None) -> list[ET.Element]:
    """The JUnit failures of the spec at ``path`` (``line`` of a JSON Lines file)."""
    cases = [c for c in batch.junit.iter("testcase")
             if c.get("file") == path and c.get("line") == (str(line) if line else None)]
    assert len(cases) == 1, (path, line)
    return cases[0].findall("failure")


# -- the batch as a whole --------------------------------------------------------------------

def test_the_batch_goes_on_and_exits_one(batch):
    assert batch.proc.returncode == 1, batch.proc.stderr
    expected = len(CASES) + 1 + len(JSONL_LINES)  # + the valid spec; blank line: no row
    assert batch.summary["specs"] == expected == len(batch.rows)
    assert not [r for r in batch.rows.values() if r["status"] in ("not_run", "error",
                                                                   "worker_died", "timeout")]


def test_no_traceback_anywhere(batch):
    for text in (batch.proc.stderr, batch.proc.stdout, json.dumps(batch.summary),
                 ET.tostring(batch.junit, encoding="unicode")):
        assert "Traceback" not in text
        assert "internal error" not in text


def test_the_valid_specs_are_solved_with_result_files(batch):
    valid = batch.rows[_path(batch, VALID)]
    line = batch.rows[f"{batch.specs / JSONL}:1"]
    for row, stem in ((valid, VALID), (line, "jsonl-valid")):
        assert row["ok"] and row["status"] in ("optimal", "acceptable"), row
        assert row["result"] == f"{stem}.json" and (batch.out / row["result"]).is_file()
        assert row["errors"] == [] and 1 < row["tuned"]["position_gain"] < 200
        assert not _annotations(batch, row["path"], row["line"])
        assert not _failures(batch, row["path"], row["line"])


def test_only_the_valid_specs_are_ok(batch):
    ok = {label for label, row in batch.rows.items() if row["ok"]}
    assert ok == {_path(batch, VALID), f"{batch.specs / JSONL}:1"}
    failing = len(batch.rows) - len(ok)
    assert len(batch.annotations) == failing
    assert batch.junit.get("failures") == str(failing)


def test_no_result_files_but_the_valid_ones(batch):
    written = {p.name for p in batch.out.glob("*.json")} - {"summary.json"}
    assert written == {f"{VALID}.json", "jsonl-valid.json"}


# -- each bad spec -----------------------------------------------------------------------------

def _assert_invalid(batch: Batch, row: dict, pointer: str, says: str,
                    line: int | None = None) -> None:
    assert row["status"] == "invalid" and row["ok"] is False, row
    assert row["line"] == line
    assert row["result"] is None and not (batch.out / f"{row['id']}.json").exists()
    assert len(row["errors"]) == 1, row["errors"]  # one defect, one error
    error = row["errors"][0]
    assert error["pointer"] == pointer, row["errors"]
    assert says in error["message"], error
    assert error["message"] and error["message"] in row["message"]
    if error["pointer"]:
        assert row["message"].startswith(f"{error['pointer']}: "), row["message"]
    annotations = _annotations(batch, row["path"], line)
    assert len(annotations) == 1, (row["path"], batch.annotations)
    if error["pointer"]:
        assert f"{error['pointer']}: " in annotations[0]
    failures = _failures(batch, row["path"], line)
    assert len(failures) == 1 and failures[0].get("type") == "invalid"
    assert says in failures[0].get("message")


@pytest.mark.parametrize("case", _ids(CASES))
def test_bad_spec_is_invalid_with_a_clear_error(batch, case):
    _assert_invalid(batch, batch.rows[_path(batch, case.id)], case.pointer, case.says)


@pytest.mark.parametrize("line", [n for n, expected in JSONL_LINES.items() if expected],
                         ids=lambda n: f"jsonl-line-{n}")
def test_bad_jsonl_line_is_its_own_row(batch, line):
    name, pointer, says = JSONL_LINES[line]
    label = f"{batch.specs / JSONL}:{line}"
    row = batch.rows[label]
    assert row["path"] == str(batch.specs / JSONL) and row["id"] == name
    _assert_invalid(batch, row, pointer, says, line=line)


def test_blank_jsonl_line_is_skipped(batch):
    lines = sorted(r["line"] for r in batch.rows.values() if r["path"].endswith(JSONL))
    assert lines == sorted(JSONL_LINES)
