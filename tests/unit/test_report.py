"""Pieces of the report: which reported value a figure marks, the Bode range, and the page
of a result with nothing to draw (a failed tuning still gets its page)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from feedtune.report import build_figures, write_report
from feedtune.report.figures import bode_range, metric
from feedtune.validate.software_servo import ServoModel

DATA = Path(__file__).resolve().parents[1] / "data"


def test_metric_picks_the_entry_whose_options_match():
    result = {"metrics": {
        "iae": {"metric": "iae", "value": 1.0, "options": {"input": "step", "time": "absolute"}},
        "iae(ramp)": {"metric": "iae", "value": 2.0, "options": {"input": "ramp", "time": "absolute"}},
        "x": {"metric": "overshoot", "value": None, "options": {}}}}
    assert metric(result, "iae", input="ramp") == 2.0
    assert metric(result, "iae", input="step", time="absolute") == 1.0
    assert metric(result, "overshoot") is None and metric(result, "m_peak") is None


def test_a_sampled_bode_ends_at_the_nyquist_frequency():
    low, high = bode_range(ServoModel(18.0, 0.02, 0.015625))
    assert high == pytest.approx(math.pi / 0.015625, rel=1e-5) and low < high / 100
    low, high = bode_range(ServoModel(18.0, 0.02))  # poles −25 ± 16.6j, |p| = 30 rad/s
    assert (low, high) == pytest.approx((1.0, 900.0), rel=1e-12)


def test_a_failed_tuning_gets_a_page_saying_what_is_missing(tmp_path):
    result = json.loads((DATA / "tian-vf-pulse.result.json").read_text())
    result.update(success=False, status="solver_failed", tuned={})
    figures = build_figures(result)
    assert all(png is None and why == "nothing was tuned" for _, _, png, why in figures)
    written = write_report(result, tmp_path)
    assert written == [tmp_path / "report.html"]
    page = written[0].read_text()
    assert "solver_failed" in page and page.count("Not drawn: nothing was tuned") == len(figures)


def test_text_from_the_result_is_escaped(tmp_path):
    result = json.loads((DATA / "tian-vf-pulse.result.json").read_text())
    result["name"] = "<script>alert(1)</script>"
    result["spec"]["description"] = "</pre><script>alert(2)</script>"
    result["spec"]["plant"]["type"] = "<b>x</b>"
    page = write_report(result, tmp_path)[0].read_text()
    assert "<script>" not in page and "<b>x" not in page
    assert "&lt;script&gt;alert(1)" in page and "&lt;/pre&gt;&lt;script&gt;alert(2)" in page


def test_a_report_killed_while_writing_leaves_files_the_next_one_may_replace(tmp_path,
                                                                            monkeypatch):
    """The manifest lists old and new digests while files are replaced: after a failure
    between two files the directory holds only listed files, and a rerun completes."""
    from feedtune.report import output

    result = json.loads((DATA / "tian-vf-pulse.result.json").read_text())
    figures = build_figures(result)
    write_report(result, tmp_path, figures)
    result["name"] = "renamed"  # a different page: report.html must be replaced
    real, calls = output.write_atomic, []

    def dies_on_the_second_file(path, data):
        calls.append(path.name)
        if len(calls) == 3:  # pending manifest, first file, then the kill
            raise KeyboardInterrupt
        real(path, data)

    monkeypatch.setattr(output, "write_atomic", dies_on_the_second_file)
    with pytest.raises(KeyboardInterrupt):
        write_report(result, tmp_path, figures)
    assert calls[0] == output.MANIFEST
    monkeypatch.setattr(output, "write_atomic", real)
    written = write_report(result, tmp_path, figures)
    assert "renamed" in written[0].read_text()
    manifest = output.read_manifest(tmp_path)
    assert sorted(manifest) == sorted(p.name for p in written)
    assert all(len(digests) == 1 for digests in manifest.values())
