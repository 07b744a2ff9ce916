"""``feedtune simulate`` and ``feedtune tune`` on a machine spec, through the real entry
point: stdout is the JSON only, bad input is exit 2 naming the field by JSON pointer."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

from feedtune_cli import run_cli

REPO = Path(__file__).resolve().parents[2]
MACHINE = REPO / "examples" / "machine" / "two-axes.json"
PROGRAM = REPO / "examples" / "machine" / "arch-pocket.ngc"


def run(*args: str) -> subprocess.CompletedProcess:
    """``feedtune ARGS`` through the real entry point in this process (bytes out;
    tests/feedtune_cli.py): nothing here tests the process itself."""
    return run_cli(*args, cwd=REPO)


def test_simulate_writes_the_metrics(tmp_path):
    proc = run("simulate", str(MACHINE), "--program", str(PROGRAM), "--report",
               str(tmp_path / "rep"))
    assert proc.returncode == 0, proc.stderr.decode()
    document = json.loads(proc.stdout)
    metrics = document["metrics"]
    # the 10 mm right angle at 50 mm/s with lags of 2.5 and 1.7 mm: a contour error
    # between a tenth of a millimetre and the lag itself
    assert 1e-4 < metrics["max_contour_error"] < 2.5e-3
    assert metrics["corners"][0]["position"][:2] == [0.01, 0.0]
    assert (tmp_path / "rep" / "path.png").stat().st_size > 0


def test_bad_machine_spec_is_exit_2_with_pointer(tmp_path):
    raw = json.loads(MACHINE.read_text())
    raw["axes"]["y"]["plant"]["time_constant"] = -1
    raw["program"] = "/etc/passwd"  # a spec may not name a file: unknown key
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(raw))
    proc = run("simulate", str(bad), "--program", str(PROGRAM))
    assert proc.returncode == 2
    err = proc.stderr.decode()
    assert "/axes/y/plant/time_constant" in err and "/program" in err
    assert proc.stdout == b""


def test_axis_may_not_set_the_sampling_period(tmp_path):
    raw = json.loads(MACHINE.read_text())
    raw["axes"]["x"]["tunables"]["sampling_period"] = {"value": 0.002}
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(raw))
    proc = run("simulate", str(bad), "--program", str(PROGRAM))
    assert proc.returncode == 2
    assert "/axes/x/tunables/sampling_period" in proc.stderr.decode()


def test_no_path_is_exit_2():
    proc = run("simulate", str(MACHINE))
    assert proc.returncode == 2 and b"/path" in proc.stderr


def test_tune_holds_the_tolerance(tmp_path):
    """Matched gains and the feed override tuned: the result holds the 100 µm tolerance,
    equal velocity constants, and a feed override inside its bounds."""
    out = tmp_path / "out.json"
    proc = run("tune", str(MACHINE), "--program", str(PROGRAM), "-o", str(out))
    assert proc.returncode == 0, proc.stderr.decode()
    result = json.loads(out.read_text())
    assert result["status"] == "optimal"
    assert result["metrics"]["max_contour_error"] <= 1e-4
    cv = result["velocity_constants"]
    assert cv["x"] == cv["y"]
    assert 0.1 <= result["feed_override"] <= 3


def test_cross_coupling_cuts_the_slot_error():
    """examples/machine: the 30° slot with mismatched axes (C_v 20 and 30 1/s, τ 20 and
    30 ms): Koren's cross-coupled PI cuts the RMS contour error by more than half (the
    README's comparison); both runs cut the same program in the same time."""
    slot = REPO / "examples" / "machine" / "slot-30deg.ngc"
    plain, coupled = (json.loads(run("simulate", str(REPO / "examples" / "machine" / name),
                                     "--program", str(slot)).stdout)["metrics"]
                      for name in ("two-axes.json", "two-axes-ccc.json"))
    assert coupled["rms_contour_error"] < plain["rms_contour_error"] / 2
    assert coupled["cycle_time"] == plain["cycle_time"]
