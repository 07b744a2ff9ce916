"""``feedtune chart ...`` and ``feedtune select`` through the real entry point
(``feedtune.__main__.run`` in this process, tests/feedtune_cli.py): exit statuses, the
files written, and errors naming the option. Grids are kept small through the options so the whole file runs in seconds."""

from __future__ import annotations

import csv
import io
import json
import math
import subprocess
from pathlib import Path

import pytest

from feedtune_cli import run_cli

REPO = Path(__file__).resolve().parents[2]
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def run(*args: str, cwd: Path = REPO) -> subprocess.CompletedProcess:
    """``feedtune ARGS`` through the real entry point in this process (text out;
    tests/feedtune_cli.py), never raising on exit status."""
    return run_cli(*args, cwd=cwd, text=True)


def run_all(invocations: dict[str, list[str]]) -> dict[str, subprocess.CompletedProcess]:
    return {name: run(*args) for name, args in invocations.items()}


@pytest.fixture(scope="module")
def charts(tmp_path_factory):
    out = tmp_path_factory.mktemp("charts")
    procs = run_all({
        "loci": ["chart", "loci", "--out", str(out / "loci.png"), "--data", str(out / "loci.json"),
                 "--ratio-max", "1", "--points", "3"],
        "min-radius": ["chart", "min-radius", "--out", str(out / "r.png"), "--data",
                       str(out / "r.csv"), "--tau-fm-min", "160", "--tau-fm-max", "200",
                       "--points", "2", "--blu", "5e-6"],
        "selection": ["chart", "selection", "--out", str(out / "s.png"), "--data",
                      str(out / "s.json"), "--time-constant", "0.02", "--blu", "5e-6",
                      "--max-velocity", "0.04"],
    })
    return out, procs


def _png(path: Path) -> bytes:
    data = path.read_bytes()
    assert data.startswith(PNG_SIGNATURE) and len(data) > 10_000
    return data


def test_chart_loci(charts):
    out, procs = charts
    proc = procs["loci"]
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout == ""
    _png(out / "loci.png")
    assert "T/τ = 0.5 (2/3)" in proc.stderr and "wrote" in proc.stderr  # progress on stderr
    data = json.loads((out / "loci.json").read_text())
    assert data["figure"] == "Koren 1979 Fig 6"
    assert set(data["series"]) == {"min_iae", "min_radial_error", "damping_0707"}
    er = data["series"]["min_radial_error"]["points"]
    assert [p["ratio"] for p in er] == [0.0, 0.5, 1.0]
    for p in er:  # eq 40, see tests/reference/test_koren_charts.py for the tolerance
        assert p["k_tau"] == pytest.approx(1 / (p["ratio"] + 2), rel=1e-4)
    assert data["series"]["min_iae"]["points"][0]["k_tau"] == pytest.approx(0.567, rel=0.01)
    assert data["closed_forms"]["eq40"]["points"]


def test_chart_min_radius(charts):
    out, procs = charts
    proc = procs["min-radius"]
    assert proc.returncode == 0, proc.stderr
    _png(out / "r.png")
    rows = list(csv.DictReader(io.StringIO((out / "r.csv").read_text())))
    series = {r["series"] for r in rows}
    assert {"reference_pulse_min_iae", "sampled_data_min_iae", "reference_pulse_min_radial_error",
            "sampled_data_min_radial_error", "eq34", "eq39"} <= series
    tuned = {(r["series"], float(r["tau_fm"])): r for r in rows if r.get("status")}
    # 219 mm (Fig 8, BLU 0.01 mm: r/BLU = 21 900) and 7 mm (BLU 5 µm: r/BLU = 1.4e3)
    assert float(tuned["sampled_data_min_iae", 200.0]["r_blu"]) == pytest.approx(21900, rel=0.01)
    assert float(tuned["reference_pulse_min_radial_error", 160.0]["r_blu"]) == \
        pytest.approx(1400, abs=50)


def test_chart_selection(charts):
    out, procs = charts
    proc = procs["selection"]
    assert proc.returncode == 0, proc.stderr
    _png(out / "s.png")
    data = json.loads((out / "s.json").read_text())
    assert data["figure"] == "Koren 1979 Fig 9"
    assert data["design"]["region"] == "either"
    assert data["design"]["pulse_rate"] == pytest.approx(8000)
    p = data["series"]["eq27"]["points"][0]
    assert p["f_m"] * p["tau"] == pytest.approx(400 / math.pi, rel=1e-12)


@pytest.mark.parametrize("args, option", [
    (["chart", "loci", "--out", "x.txt"], "--out"),
    (["chart", "loci", "--out", "/no/such/dir/x.png"], "--out"),
    (["chart", "loci", "--out", "x.png", "--data", "x.xml"], "--data"),
    (["chart", "loci", "--out", "x.png", "--ratio-min", "2", "--ratio-max", "1"], "--ratio-max"),
    (["chart", "loci", "--out", "x.png", "--time-constant", "-0.02"], "--time-constant"),
    (["chart", "loci", "--out", "x.png", "--points", "1"], "--points"),
    (["chart", "min-radius", "--out", "x.png", "--tau-fm-min", "0"], "--tau-fm-min"),
    (["chart", "min-radius", "--out", "x.png", "--encoder-ratio", "abc"], "--encoder-ratio"),
    (["chart", "selection", "--out", "x.png", "--fm-min", "1e5", "--fm-max", "1e4"], "--fm-max"),
    (["chart", "selection", "--out", "x.png", "--blu", "5e-6"], "--time-constant"),
    (["chart", "loci"], "--out"),
    (["select", "--time-constant", "0.02", "--max-velocity", "0.04"], "--blu"),
    (["select", "--time-constant", "0.02", "--blu", "5e-6", "--max-velocity", "0.04",
      "--emit-spec", "/no/such/dir/spec.json"], "--emit-spec"),
    (["select", "--time-constant", "0", "--blu", "5e-6", "--max-velocity", "0.04"], "--time-constant"),
    (["select", "--time-constant", "0.02", "--blu", "5e-6", "--max-velocity", "0.04",
      "--json", "--emit-spec", "-"], "--emit-spec"),
])
def test_bad_options_name_the_option(args, option, tmp_path):
    proc = run(*args, cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    assert option in proc.stderr
    assert not list(tmp_path.iterdir())  # nothing written


def test_select_text_json_and_emitted_specs_tune(tmp_path):
    rp_spec, sd_spec = tmp_path / "rp.json", tmp_path / "sd.json"
    procs = run_all({
        "text": ["select", "--time-constant", "0.02", "--blu", "5e-6", "--max-velocity", "0.04",
                 "--fs-rounding", "power-of-two", "--radius", "0.008", "--emit-spec", str(rp_spec)],
        "json": ["select", "--time-constant", "0.02", "--blu", "1e-6", "--max-velocity", "0.02",
                 "--json", "--emit-spec", str(sd_spec)],
        "none": ["select", "--time-constant", "0.005", "--blu", "1e-6", "--max-velocity", "0.02",
                 "--json"],
        "tight": ["select", "--time-constant", "0.02", "--blu", "5e-6", "--max-velocity", "0.04",
                  "--radius", "0.005"],
    })
    text = procs["text"]
    assert text.returncode == 0, text.stderr
    assert "recommended: reference-pulse" in text.stdout
    assert "K = 25 [1/s]" in text.stdout and "f_s = 64 [Hz]" in text.stdout
    assert "required radius 0.008 [m] at V_m: met" in text.stdout

    as_json = procs["json"]
    assert as_json.returncode == 0, as_json.stderr
    rec = json.loads(as_json.stdout)
    assert rec["technique"] == "sampled_data" and rec["region"] == "sampled_data"
    sd = rec["designs"]["sampled_data"]
    assert sd["gain"] * (sd["sampling_period"] + 0.04) == pytest.approx(1, rel=1e-12)
    assert sd["sampling_frequency"] == pytest.approx(4 / (math.pi * 0.02), rel=1e-12)
    assert sd["min_radius"] > 0

    assert procs["none"].returncode == 1
    assert json.loads(procs["none"].stdout)["technique"] is None
    assert procs["tight"].returncode == 1 and "NOT met" in procs["tight"].stdout

    # the emitted specs are accepted by `feedtune tune` and tune to the recommended design
    tuned = run_all({"rp": ["tune", str(rp_spec), "-q"], "sd": ["tune", str(sd_spec), "-q"]})
    for name, proc in tuned.items():
        assert proc.returncode == 0, (name, proc.stderr)
    rp_result = json.loads(tuned["rp"].stdout)
    # minimum radial error on the 8 mm circle at 40 mm/s: K = (1 + (ωτ)²)/(2τ) = 25.25 1/s
    assert rp_result["tuned"]["position_gain"]["value"] == pytest.approx(25.25, rel=1e-6)
    sd_result = json.loads(tuned["sd"].stdout)
    assert sd_result["tuned"]["sampling_period"]["value"] == pytest.approx(sd["sampling_period"])
    assert sd_result["success"]


def test_select_emit_spec_to_stdout_is_the_only_stdout():
    proc = run("select", "--time-constant", "0.02", "--blu", "5e-6", "--max-velocity", "0.04",
               "--emit-spec", "-")
    assert proc.returncode == 0, proc.stderr
    spec = json.loads(proc.stdout)
    assert spec["plant"]["technique"] == "reference_pulse"
    assert "recommended: reference-pulse" in proc.stderr
