"""`feedtune report` and `feedtune tune --report` through the real entry point.

The page must be self-contained (every figure a data URI), list every tuned value, metric,
constraint and validation row of the result, and say why a figure is left out.
Results of the slow Bhatia tunings (20 s each) are stored in tests/data/ and re-read with
the strict result reader, so a change of the result format shows here.
"""

from __future__ import annotations

import base64
import json
import re
import shutil
import subprocess
from html.parser import HTMLParser
from pathlib import Path

import pytest

from feedtune_cli import run_cli

REPO = Path(__file__).resolve().parents[2]
DATA = REPO / "tests" / "data"
BHATIA = DATA / "bhatia-1971-hydraulic.result.json"


def feedtune(*args: str) -> subprocess.CompletedProcess:
    """``feedtune ARGS`` through the real entry point in this process (bytes out;
    tests/feedtune_cli.py)."""
    return run_cli(*args, cwd=REPO)


class _Page(HTMLParser):
    """Images (src), the text of every table cell, table rows (cell texts), <pre> texts and
    the attributes of <html> and every <meta>."""

    def __init__(self):
        super().__init__()
        self.images, self.cells, self.rows, self.pre, self.meta = [], [], [], [], []
        self.html, self._cell, self._pre = {}, None, None

    def handle_starttag(self, tag, attrs):
        if tag == "img":
            self.images.append(dict(attrs)["src"])
        if tag == "html":
            self.html = dict(attrs)
        if tag == "meta":
            self.meta.append(dict(attrs))
        if tag == "tr":
            self.rows.append([])
        if tag == "td":
            self._cell = ""
        if tag == "pre":
            self._pre = ""

    def handle_data(self, data):
        if self._cell is not None:
            self._cell += data
        if self._pre is not None:
            self._pre += data

    def handle_endtag(self, tag):
        if tag == "td":
            self.cells.append(self._cell)
            self.rows[-1].append(self._cell)
            self._cell = None
        if tag == "pre":
            self.pre.append(self._pre)
            self._pre = None


def parse(path: Path) -> _Page:
    page = _Page()
    page.feed(path.read_text(encoding="utf-8"))
    return page


@pytest.fixture(scope="module")
def sato_report(tmp_path_factory):
    """sato-finish tuned with --report: a sampled loop behind an interpolator."""
    out = tmp_path_factory.mktemp("sato")
    proc = feedtune("tune", "-q", str(REPO / "examples" / "sato-finish.json"), "-o",
                    str(out / "result.json"), "--report", str(out / "report"))
    assert proc.returncode == 0, proc.stderr.decode()
    return out


@pytest.fixture(scope="module")
def bhatia_report(tmp_path_factory):
    """The stored Bhatia hydraulic result reported once (≈ 2.5 s of CPU a report), for the
    tests that only read a report of it or copy it: (report directory, the process).
    Tests never write into it."""
    out = tmp_path_factory.mktemp("bhatia") / "report"
    proc = feedtune("report", str(BHATIA), "--out", str(out))
    assert proc.returncode == 0, proc.stderr.decode()
    return out, proc


def test_tune_report_writes_every_figure_embedded(sato_report):
    report = sato_report / "report"
    pngs = sorted(p.name for p in report.glob("*.png"))
    assert pngs == ["bode.png", "circle.png", "poles.png", "responses.png"]
    page = parse(report / "report.html")
    embedded = [base64.b64decode(src.removeprefix("data:image/png;base64,"))
                for src in page.images]
    assert all(src.startswith("data:image/png;base64,") for src in page.images)
    assert sorted(embedded) == sorted((report / name).read_bytes() for name in pngs)
    assert all(png.startswith(b"\x89PNG") for png in embedded)


def test_report_tables_list_the_whole_result(sato_report):
    result = json.loads((sato_report / "result.json").read_text())
    cells = parse(sato_report / "report" / "report.html").cells
    for name in result["tuned"]:
        assert name in cells
    labels = {c.split("(")[0] for c in cells}
    for m in result["metrics"].values():
        assert m["metric"] in labels
    assert sum(c == "OK" for c in cells) >= len(result["constraints"]) + len(
        [e for e in result["validation"]["entries"] if e["ok"]])
    # the report names a metric with options as the result's metrics keys do
    # (feedtune.schema.labels)
    assert "circle_roughness(radius=0.05,feed=0.05)" in cells


def test_report_command_is_deterministic(bhatia_report, tmp_path):
    """The same result gives the same bytes (no dates in PNGs, the page or the manifest):
    two runs, each a process of its own."""
    first, second = bhatia_report[0], tmp_path / "b"
    proc = feedtune("report", str(BHATIA), "--out", str(second))
    assert proc.returncode == 0, proc.stderr.decode()
    assert sorted(p.name for p in first.iterdir()) == sorted(p.name for p in second.iterdir())
    for path in first.iterdir():
        assert path.read_bytes() == (second / path.name).read_bytes(), path.name


def test_a_later_report_removes_its_stale_figures_and_nothing_else(sato_report, tmp_path):
    """circle.png, bode.png and poles.png of a sato report are stale once Tian's pulse
    generator (a rotary axis without poles: its report draws the responses alone, ≈ 0.1 s
    of CPU against ≈ 0.8 s for Bhatia's three figures) is reported into the same
    directory: removed; the user's files next to them, of other names, stay. The sato
    report is the fixture's (`tune --report`, the files and manifest `feedtune report` of
    its result writes), copied: drawn once for the module."""
    out = tmp_path / "report"
    shutil.copytree(sato_report / "report", out)
    stale = ("bode.png", "circle.png", "poles.png")
    assert all((out / name).exists() for name in stale)
    mine = {"step.png": b"my step plot", "notes.txt": b"x", "report.html.bak": b"old"}
    for name, data in mine.items():
        (out / name).write_bytes(data)
    proc = feedtune("report", str(DATA / "tian-vf-pulse.result.json"), "--out", str(out))
    assert proc.returncode == 0, proc.stderr.decode()
    assert not any((out / name).exists() for name in stale)
    for name, data in mine.items():
        assert (out / name).read_bytes() == data, name
    manifest = json.loads((out / ".feedtune-report.json").read_text())
    assert sorted(manifest["files"]) == ["report.html", "responses.png"]


@pytest.mark.parametrize("name", ["bode.png", "report.html", "circle.png"])
def test_a_file_of_a_report_name_the_report_did_not_write_is_never_replaced(tmp_path, name):
    """Even a name this result would not draw (circle.png on a rotary axis): the directory's
    files of the report's names are the report's or left alone, exit 2 naming the file."""
    out = tmp_path / "out"
    out.mkdir()
    (out / name).write_bytes(b"the user's own")
    proc = feedtune("report", str(DATA / "bhatia-1971-hydraulic.result.json"), "--out", str(out))
    assert proc.returncode == 2
    err = proc.stderr.decode()
    assert str(out / name) in err and "'--out'" in err and "does not overwrite" in err
    assert sorted(p.name for p in out.iterdir()) == [name]
    assert (out / name).read_bytes() == b"the user's own"


def test_a_figure_changed_since_the_report_wrote_it_is_the_users(bhatia_report, tmp_path):
    out = tmp_path / "out"
    shutil.copytree(bhatia_report[0], out)  # a report (its manifest holds hashes, no paths)
    (out / "poles.png").write_bytes(b"annotated by hand")
    proc = feedtune("report", str(BHATIA), "--out", str(out))
    assert proc.returncode == 2 and str(out / "poles.png") in proc.stderr.decode()
    assert (out / "poles.png").read_bytes() == b"annotated by hand"


def test_a_manifest_the_report_did_not_write_stops_it(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / ".feedtune-report.json").write_text('{"files": {"bode.png": ["0"]}}')
    proc = feedtune("report", str(DATA / "tian-vf-pulse.result.json"), "--out", str(out))
    assert proc.returncode == 2
    assert str(out / ".feedtune-report.json") in proc.stderr.decode()
    assert sorted(p.name for p in out.iterdir()) == [".feedtune-report.json"]


def test_tune_checks_the_report_directory_before_solving(tmp_path):
    """A conflict found after a long tuning would still exit 2: it is found first, before
    anything is solved or written."""
    out = tmp_path / "report"
    out.mkdir()
    (out / "responses.png").write_bytes(b"mine")
    proc = feedtune("tune", str(REPO / "examples" / "koren-1979-sampled-data.json"), "-o",
                    str(tmp_path / "result.json"), "--report", str(out))
    assert proc.returncode == 2
    assert str(out / "responses.png") in proc.stderr.decode() and "'--report'" in proc.stderr.decode()
    assert not (tmp_path / "result.json").exists() and "start 1/" not in proc.stderr.decode()
    assert (out / "responses.png").read_bytes() == b"mine"


def test_the_page_shows_the_plant_with_units_the_provenance_and_the_spec(bhatia_report):
    result = json.loads(BHATIA.read_text())
    page = parse(bhatia_report[0] / "report.html")
    rows = {row[0]: row[1:] for row in page.rows if row}
    assert rows["bulk_modulus"][:2] == ["689475729.0", "Pa"]
    assert rows["displacement"][:2] == ["1.38233e-07", "m³/rad"]
    assert rows["hydraulic_natural_frequency"][:2] == ["75.0", "rad/s"]
    assert rows["torque_motor_natural_frequency"][:1] == ["null"]
    assert "Effective bulk modulus" in rows["bulk_modulus"][2]
    for key in ("feedtune", "casadi", "ipopt", "python", "spec_sha256"):
        assert [result["provenance"][key]] in rows.values(), key
    assert [json.loads(text) for text in page.pre] == [result["spec"]]
    assert page.html.get("lang") == "en"
    assert {"charset": "utf-8"} in page.meta
    assert {"name": "viewport", "content": "width=device-width, initial-scale=1"} in page.meta


def test_figures_a_plant_cannot_offer_are_named_with_the_reason(bhatia_report):
    out, proc = bhatia_report
    text = (out / "report.html").read_text()
    assert re.search(r"Circle test</h2>\s*<p class=\"note\">Not drawn: [^<]+", text)
    assert "not drawn: " in proc.stderr.decode()


@pytest.mark.parametrize("make, message", [
    (lambda d: d / "missing.json", "no such result file"),
    (lambda d: REPO / "examples" / "sato-finish.json", "this is a spec, not a result"),
    (lambda d: (d / "bad.json").write_text("{\"name\": NaN}") and d / "bad.json",
     "NaN"),
])
def test_unreadable_results_exit_2_naming_the_file(tmp_path, make, message):
    path = make(tmp_path)
    proc = feedtune("report", str(path), "--out", str(tmp_path / "out"))
    assert proc.returncode == 2
    err = proc.stderr.decode()
    assert str(path) in err and message in err
    assert not (tmp_path / "out").exists()


def test_out_must_be_a_directory(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    proc = feedtune("report", str(DATA / "tian-vf-pulse.result.json"), "--out", str(blocker))
    assert proc.returncode == 2
    assert "'--out'" in proc.stderr.decode() and "not a directory" in proc.stderr.decode()
