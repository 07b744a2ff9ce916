"""Robust tuning through the real entry point (``feedtune.__main__.run`` in the test process,
tests/feedtune_cli.py): a spec with an uncertain time constant tunes to a result with its robust block and validated scenarios,
the summary says so, ``validate`` accepts it, and a malformed range exits 2 naming the
place it was written."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

from feedtune_cli import run_cli

REPO = Path(__file__).resolve().parents[2]
#: Koren's reference-pulse servo with τ anywhere in 10-20 ms, ζ ≥ 0.7 (solves in ~0.1 s)
SPEC = {"name": "robust-servo-cli",
        "plant": {"type": "software_servo", "technique": "reference_pulse",
                  "time_constant": {"min": 0.010, "max": 0.020}, "blu": 5e-6,
                  "max_velocity": 0.04},
        "tunables": {"position_gain": {"min": 1, "max": 200}},
        "objective": [{"metric": "radial_error", "radius": 0.008, "feed": 0.04}],
        "constraints": [{"metric": "damping_ratio", "min": 0.7}],
        "solver": {"multistart": 1}}


def feedtune(*args: str) -> subprocess.CompletedProcess:
    """``feedtune ARGS`` through the real entry point in this process (text out;
    tests/feedtune_cli.py): nothing here tests the process itself."""
    return run_cli(*args, cwd=REPO, text=True)


def test_tune_writes_the_robust_block_and_its_validation(tmp_path):
    path = tmp_path / "spec.json"
    path.write_text(json.dumps(SPEC))
    proc = feedtune("tune", str(path))
    assert proc.returncode == 0, proc.stderr
    result = json.loads(proc.stdout)  # stdout is the result's JSON only
    robust = result["robust"]
    assert robust["converged"] and [s["origin"] for s in robust["scenarios"]] == [
        "nominal", "corner", "corner", "interior", "interior"]
    assert robust["worst_cases"][0]["parameters"] == {"time_constant": 0.02}
    assert result["spec"]["plant"]["time_constant"] == 0.015  # the nominal, canonical form
    assert result["spec"]["robust"]["parameters"]["time_constant"]["min"] == 0.010
    validation = result["validation"]
    assert validation["ok"] and len(validation["scenarios"]) == 5
    assert "robust (nominal objective): 5 scenarios (1 nominal, 2 corner, 2 interior), " \
           "1 round(s), converged" in proc.stderr
    assert "worst damping_ratio = 0.7 [1] at time_constant = 0.02" in proc.stderr
    assert robust["search"].startswith("a 41-point grid over time_constant and every scenario (46 points)"
                                       "; from each constraint's worst point, bounded Brent")
    assert f"  searched: {robust['search']}" in proc.stderr.splitlines()


def test_validate_accepts_a_robust_spec(tmp_path):
    path = tmp_path / "spec.json"
    path.write_text(json.dumps(SPEC))
    proc = feedtune("validate", str(path))
    assert proc.returncode == 0, proc.stderr


def test_a_malformed_range_exits_2_with_its_pointer(tmp_path):
    bad = json.loads(json.dumps(SPEC))
    bad["plant"]["time_constant"] = {"min": -0.01, "max": 0.02}
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(bad))
    proc = feedtune("tune", str(path))
    assert proc.returncode == 2
    assert proc.stdout == ""
    assert f"error: {path}: /plant/time_constant/min: -0.01: Input should be greater than 0" \
        in proc.stderr.splitlines()
