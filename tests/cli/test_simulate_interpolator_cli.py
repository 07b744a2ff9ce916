"""``feedtune simulate`` with the interpolator's in-position wait and normal-acceleration
limit, through the real entry point: the JSON reports them; bad values are exit 2 at
their pointer."""

from __future__ import annotations

import json
from pathlib import Path

from feedtune_cli import run_cli

REPO = Path(__file__).resolve().parents[2]
FIG38 = REPO / "examples" / "machine" / "bhatia-fig38.json"
MACHINE = REPO / "examples" / "machine" / "two-axes.json"


def run(*args: str):
    return run_cli(*args, cwd=REPO)


def test_fig38_with_his_special_code_reports_the_wait_and_the_overshoot_at_b(tmp_path):
    """examples/machine/bhatia-fig38.json with exact_stop_at_b: the hold at B (block 1,
    segment 1) is in metrics.interpolation.in_position, and the stop at B overshoots by
    more than his pulse weight (.0002 in)."""
    raw = json.loads(FIG38.read_text())
    raw["path"]["exact_stop_at_b"] = True
    spec = tmp_path / "fig38-stop.json"
    spec.write_text(json.dumps(raw))
    proc = run("simulate", str(spec))
    assert proc.returncode == 0, proc.stderr.decode()
    metrics = json.loads(proc.stdout)["metrics"]
    waits = {w["segment"]: w for w in metrics["interpolation"]["in_position"]}
    assert set(waits) == {0, 1, 6} and waits[1]["hold"] > 0
    at_b = next(s for s in metrics["stops"] if s["segment"] == 1)
    assert at_b["overshoot"] > 0.0002 * 0.0254


def test_small_arc_slowed_and_bad_limit_refused(tmp_path):
    """A 1 mm-radius arc at 50 mm/s (2.5 m/s² centripetal) with a 0.5 m/s² limit is listed
    with its feed √(0.5 · 0.001) m/s; a negative limit is exit 2 at its pointer."""
    raw = json.loads(MACHINE.read_text())
    raw["interpolator"]["max_normal_acceleration"] = 0.5
    raw["feed_override"] = {"value": 1.0}
    spec = tmp_path / "m.json"
    spec.write_text(json.dumps(raw))
    program = tmp_path / "arc.ngc"
    program.write_text("G21 G90\nG1 X5 F3000\nG3 X6 Y1 R1\nG1 Y6\nM2\n")
    proc = run("simulate", str(spec), "--program", str(program))
    assert proc.returncode == 0, proc.stderr.decode()
    (arc,) = json.loads(proc.stdout)["metrics"]["interpolation"]["arcs_slowed"]
    assert arc["line"] == 3 and abs(arc["limited_feed"] - (0.5 * 0.001) ** 0.5) < 1e-12
    raw["interpolator"]["max_normal_acceleration"] = -1
    spec.write_text(json.dumps(raw))
    proc = run("simulate", str(spec), "--program", str(program))
    assert proc.returncode == 2
    assert "/interpolator/max_normal_acceleration" in proc.stderr.decode()
