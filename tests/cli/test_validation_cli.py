"""``feedtune tune`` writes a validation block (feedtune.validate) and warns on stderr when
the independent re-simulation disagrees with a reported metric; Koren's examples agree."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from feedtune_cli import run_cli

REPO = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("name", ["koren-1979-sampled-data", "koren-1979-reference-pulse"])
def test_koren_examples_validate_within_tolerance(name, tmp_path):
    out = tmp_path / "result.json"
    proc = run_cli("tune", str(REPO / "examples" / f"{name}.json"), "-o", str(out), cwd=REPO)
    assert proc.returncode == 0, proc.stderr.decode()
    assert b"warning: validation" not in proc.stderr
    block = json.loads(out.read_text())["validation"]
    assert block["covered"] and block["ok"] is True
    measured = {e["metric"] for e in block["entries"]}
    assert {"iae", "ise", "itae", "radial_error", "damping_ratio", "natural_frequency",
            "velocity_constant", "min_radius", "poles", "stable"} <= measured
    assert all(e["gap"] is None or e["gap"] <= e["tolerance"] for e in block["entries"])


def test_a_gap_beyond_tolerance_warns_on_stderr(tmp_path, monkeypatch, capsys):
    """The validator patched to disagree: tune still writes its result, and warns."""
    from click.testing import CliRunner

    import feedtune.validate.block as block_module
    from feedtune.cli import main
    from feedtune.validate.tolerances import Context, judge

    original = block_module._measure

    def tampered(model, result):
        entries = original(model, result)
        first = entries[0]
        record = {"metric": first["metric"], "options": first["options"],
                  "value": first["reported"], "unit": first["unit"]}
        entries[0] = judge(record, first["validated"] * 1.5, Context(time=model.context().time))
        return entries

    monkeypatch.setattr(block_module, "_measure", tampered)
    out = tmp_path / "result.json"
    result = CliRunner().invoke(main, ["tune", "-q", str(REPO / "examples" /
                                                          "koren-1979-reference-pulse.json"),
                                       "-o", str(out)])
    assert result.exit_code == 0
    stderr = result.stderr if hasattr(result, "stderr") else result.output
    assert "warning: validation: iae(time=absolute,input=step) reported" in stderr
    assert "m·s > tolerance" in stderr and "(0.0001 × |value|)" in stderr
    block = json.loads(out.read_text())["validation"]
    assert block["ok"] is False
