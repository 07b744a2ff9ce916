"""``feedtune identify`` through the real entry point (``feedtune.__main__.run`` in the test
process, tests/feedtune_cli.py): the bundled example data identify, the plant block written
with ``-o`` tunes unchanged, bad data is exit 2 naming file, line and column with nothing
written, and the report is drawn."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest

from feedtune_cli import run_cli

REPO = Path(__file__).resolve().parents[2]
DATA = REPO / "examples" / "data"


def run(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    """``feedtune ARGS`` through the real entry point in this process (text out;
    tests/feedtune_cli.py): nothing here tests the process itself."""
    return run_cli(*args, cwd=cwd or REPO, text=True)


def test_help_names_units():
    proc = run("identify", "--help")
    assert proc.returncode == 0
    for unit in ("[s]", "[rad/s]", "[1]", "[m/(s·U)]", "[Hz or rad/s]"):
        assert unit in proc.stdout, unit


def test_software_servo_block_tunes_unchanged(tmp_path):
    """The step of Koren's drive (τ = 20 ms, K_m = 0.05 m/(s·V)) identifies within 3σ,
    and Koren's spec with the written block as its plant tunes (exit 0) to K within 2 %
    of the spec's own K = 25.25 1/s."""
    plant = tmp_path / "plant.json"
    proc = run("identify", str(DATA / "software-servo-step.csv"), "--model", "software_servo",
               "--like", "examples/koren-1979-reference-pulse.json", "-o", str(plant))
    assert proc.returncode == 0, proc.stderr
    result = json.loads(proc.stdout)
    tau = result["parameters"]["time_constant"]
    assert tau["unit"] == "s" and abs(tau["value"] - 0.02) <= 3 * tau["standard_error"]
    gain = result["parameters"]["velocity_gain"]
    assert gain["unit"] == "m/(s·V)" and abs(gain["value"] - 0.05) <= 3 * gain["standard_error"]
    block = json.loads(plant.read_text())
    assert block == result["plant"]
    spec = json.loads((REPO / "examples" / "koren-1979-reference-pulse.json").read_text())
    true_result = run("tune", "examples/koren-1979-reference-pulse.json", "-q")
    spec["plant"] = block
    (tmp_path / "spec.json").write_text(json.dumps(spec))
    tuned = run("tune", str(tmp_path / "spec.json"), "-q")
    assert tuned.returncode == 0 and true_result.returncode == 0, tuned.stderr
    k = json.loads(tuned.stdout)["tuned"]["position_gain"]["value"]
    k_true = json.loads(true_result.stdout)["tuned"]["position_gain"]["value"]
    assert k == pytest.approx(k_true, rel=0.02)


def test_several_files_and_the_report(tmp_path):
    out = tmp_path / "report"
    proc = run("identify", str(DATA / "hydraulic-frf-1.csv"), str(DATA / "hydraulic-frf-2.csv"),
               "--model", "hydraulic_rotary", "--report", str(out))
    assert proc.returncode == 0, proc.stderr
    result = json.loads(proc.stdout)
    assert [Path(d["source"]).name for d in result["data"]] == ["hydraulic-frf-1.csv",
                                                               "hydraulic-frf-2.csv"]
    assert all(0.005 < d["nrmse"] < 0.02 for d in result["data"])  # the 1 % noise
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == [
        "data-1.png", "data-2.png", "identification.html"]
    page = (out / "identification.html").read_text()
    assert "hydraulic_natural_frequency" in page and "rad/s" in page


def test_linear_model_with_dead_time_from_json():
    proc = run("identify", str(DATA / "two-mass-frf.json"), "--model", "linear", "--poles", "2",
               "--zeros", "2", "--integrators", "2", "--dead-time")
    assert proc.returncode == 0, proc.stderr
    theta = json.loads(proc.stdout)["parameters"]["dead_time"]
    assert abs(theta["value"] - 2e-4) <= 3 * theta["standard_error"]
    block = json.loads(proc.stdout)["plant"]
    assert block["model"]["denominator"][-2:] == [0.0, 0.0] and block["input_unit"] == "N·m"


@pytest.mark.parametrize("text, where", [
    ("time[s],command[V]\n" + "".join(f"{k},1\n" for k in range(9)), "bad.csv:1:1:"),
    ("time[s],command[V],position[m]\n" + "".join(f"{k},1,{k}\n" for k in range(4))
     + "4,1,nan\n" + "".join(f"{k},1,{k}\n" for k in range(5, 9)), "bad.csv:6:5:"),
    ("frequency[Hz],magnitude[rad/V],phase[deg]\n1,1,0\n3,1,0\n2,1,0\n4,1,0\n5,1,0\n",
     "bad.csv:4:1:"),
    ("time,command[V],position[m]\n" + "".join(f"{k},1,{k}\n" for k in range(9)),
     "bad.csv:1:1:"),
    ("time[s],command[V],position[m]\n0,1,0\n1,1,1\n", "bad.csv:4:1:"),
])
def test_bad_data_is_exit_2_and_writes_nothing(tmp_path, text, where):
    (tmp_path / "bad.csv").write_text(text)
    proc = run("identify", "bad.csv", "--model", "software_servo", "-o", "plant.json",
               "--report", "report", cwd=tmp_path)
    assert proc.returncode == 2
    assert proc.stderr.startswith(f"error: {where}"), proc.stderr
    assert proc.stdout == ""
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.csv"]


def test_one_bad_file_among_good_ones_keeps_an_existing_block(tmp_path):
    (tmp_path / "plant.json").write_text("old")
    (tmp_path / "bad.csv").write_text("time[s],command[V],position[m]\n")
    proc = run("identify", str(DATA / "software-servo-step.csv"), "bad.csv", "--model",
               "software_servo", "-o", "plant.json", cwd=tmp_path)
    assert proc.returncode == 2 and "bad.csv:2:1:" in proc.stderr
    assert (tmp_path / "plant.json").read_text() == "old"


@pytest.mark.parametrize("args, words", [
    # a model the data cannot determine: more parameters than points
    (["--model", "linear", "--poles", "3", "--zeros", "2"], "parameters"),
    # a model for another position unit
    (["--model", "hydraulic_rotary"], "is an axis in rad"),
    # a template of another plant type
    (["--model", "software_servo", "--like", "examples/bhatia-1971-hydraulic.json"],
     "hydraulic_rotary"),
])
def test_models_the_data_cannot_give_are_exit_2(tmp_path, args, words):
    (tmp_path / "few.csv").write_text(
        "time[s],command[V],position[m]\n" + "".join(f"{k},1,{k * k}\n" for k in range(5)))
    proc = run("identify", str(tmp_path / "few.csv"), *args, "-o", str(tmp_path / "p.json"))
    assert proc.returncode == 2, proc.stderr
    assert words in proc.stderr
    assert not (tmp_path / "p.json").exists()


def test_linear_options_with_another_model_are_a_usage_error():
    proc = run("identify", str(DATA / "software-servo-step.csv"), "--model", "software_servo",
               "--dead-time")
    assert proc.returncode == 2 and "--dead-time applies to --model linear only" in proc.stderr
