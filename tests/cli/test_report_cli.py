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
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
DATA = REPO / "tests" / "data"


def feedtune(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "feedtune", *args], capture_output=True,
                          timeout=120, cwd=REPO)


class _Page(HTMLParser):
    """Images (src) and the text of every table cell."""

    def __init__(self):
        super().__init__()
        self.images, self.cells, self._cell = [], [], None

    def handle_starttag(self, tag, attrs):
        if tag == "img":
            self.images.append(dict(attrs)["src"])
        if tag == "td":
            self._cell = ""

    def handle_data(self, data):
        if self._cell is not None:
            self._cell += data

    def handle_endtag(self, tag):
        if tag == "td":
            self.cells.append(self._cell)
            self._cell = None


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
    assert "circle_roughness(radius=0.05, feed=0.05)" in cells


def test_report_command_is_deterministic_and_replaces_stale_figures(tmp_path):
    """The same result gives the same bytes (no dates in PNGs or the page); a figure that
    a later result cannot offer is removed, not left stale."""
    first, second = tmp_path / "a", tmp_path / "b"
    source = DATA / "bhatia-1971-hydraulic.result.json"
    for out in (first, second):
        proc = feedtune("report", str(source), "--out", str(out))
        assert proc.returncode == 0, proc.stderr.decode()
    for path in first.iterdir():
        assert path.read_bytes() == (second / path.name).read_bytes(), path.name
    (first / "circle.png").write_bytes(b"stale")
    proc = feedtune("report", str(DATA / "tian-vf-pulse.result.json"), "--out", str(first))
    assert proc.returncode == 0, proc.stderr.decode()
    assert not (first / "circle.png").exists()


def test_figures_a_plant_cannot_offer_are_named_with_the_reason(tmp_path):
    proc = feedtune("report", str(DATA / "bhatia-1971-hydraulic.result.json"), "--out",
                    str(tmp_path))
    assert proc.returncode == 0
    text = (tmp_path / "report.html").read_text()
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
