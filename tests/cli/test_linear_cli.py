"""The user-defined drive from the command line: examples/user-defined-drive.json tunes and
validates (exit 0), a bad model is exit 2 naming its field and writes nothing, and
``feedtune plants`` lists the plant with units."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest

from feedtune_cli import run_cli

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "examples" / "user-defined-drive.json"


def run(*args: str, stdin: bytes = b"", cwd: Path = REPO) -> subprocess.CompletedProcess:
    """``feedtune ARGS`` through the real entry point in this process (bytes out;
    tests/feedtune_cli.py)."""
    return run_cli(*args, stdin=stdin, cwd=cwd)


@pytest.fixture(scope="module")
def tuned(tmp_path_factory) -> dict:
    out = tmp_path_factory.mktemp("linear") / "result.json"
    proc = run("tune", str(EXAMPLE), "-o", str(out))
    assert proc.returncode == 0, proc.stderr.decode()
    assert b"warning" not in proc.stderr, proc.stderr.decode()
    return json.loads(out.read_text())


def test_example_tunes_and_validates(tuned):
    """Optimal, the constraints hold, and the independent validator re-measures every
    metric within its tolerance (feedtune/validate/linear.py)."""
    assert tuned["status"] == "optimal"
    assert tuned["metrics"]["m_peak"]["value"] <= 1.3 + 1e-6  # IPOPT's constr_viol_tol scale
    assert tuned["metrics"]["phase_margin"]["value"] >= 45 - 1e-6
    block = tuned["validation"]
    assert block["covered"] and block["ok"], block
    checked = {e["metric"] for e in block["entries"]}
    assert {"bandwidth", "m_peak", "phase_margin", "gain_margin", "iae", "overshoot",
            "settling_time", "poles", "velocity_loop_poles"} <= checked


def test_result_carries_the_declared_units(tuned):
    assert tuned["tuned"]["velocity_controller.kp"]["unit"] == "N·m·s/rad"
    assert tuned["tuned"]["position_controller.kp"]["unit"] == "1/s"
    assert tuned["metrics"]["iae"]["unit"] == "rad·s"


@pytest.mark.parametrize("model, pointer", [
    ({"type": "transfer_function", "numerator": [1, 2, 3, 4, 5, 6], "denominator": [1, 0, 0]},
     "/plant/model/numerator"),
    ({"type": "state_space", "a": [[0, 1], [0, -5]], "b": [[1]], "c": [[1, 0]]},
     "/plant/model/b"),
])
def test_bad_model_exits_2_with_its_pointer_and_writes_nothing(model, pointer, tmp_path):
    spec = json.loads(EXAMPLE.read_text())
    spec["plant"]["model"] = model
    out = tmp_path / "result.json"
    proc = run("tune", "-", "-o", str(out), stdin=json.dumps(spec).encode())
    assert proc.returncode == 2
    assert pointer in proc.stderr.decode()
    assert proc.stdout == b""
    assert not out.exists()


def test_negative_dead_time_exits_2_on_validate():
    spec = json.loads(EXAMPLE.read_text())
    spec["plant"]["dead_time"] = -0.001
    proc = run("validate", "-", stdin=json.dumps(spec).encode())
    assert proc.returncode == 2
    assert "/plant/dead_time" in proc.stderr.decode()


def test_plants_lists_the_linear_plant_with_units():
    proc = run("plants", "--json")
    assert proc.returncode == 0
    linear = json.loads(proc.stdout)["linear"]
    fields = {f["name"]: f for f in linear["parameters"]}
    assert {"model", "output_unit", "input_unit", "dead_time", "velocity_feedforward"} <= set(fields)
    assert "[s]" in fields["dead_time"]["description"]
    tunables = linear["tunables"]["*"]
    assert tunables["notch.frequency"]["unit"] == "rad/s"
    assert tunables["velocity_controller.ti"]["unit"] == "s"
