"""An infinite gain margin from the command line (issue 16): Koren's reference-pulse loop
K/(s(1 + sτ)) never reaches −180° of phase, so its gain margin is +∞ (python-control's
gm = inf). ``feedtune tune`` writes it as the JSON string "Infinity", prints "inf" in its
summary, holds a bound from below on it, validates it, and the result reads back with
``feedtune.load_result`` as ``math.inf``; ``feedtune report`` draws the Bode figure
without a GM arrow; an objective term that maximises it is refused (exit 2) at its pointer.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import control
import pytest

import feedtune

from feedtune_cli import run_cli

REPO = Path(__file__).resolve().parents[2]
SPEC = json.loads((REPO / "examples" / "koren-1979-reference-pulse.json").read_text())


def write(tmp_path: Path, **changes) -> Path:
    path = tmp_path / "spec.json"
    path.write_text(json.dumps({**SPEC, "solver": {"multistart": 2}, **changes}))
    return path


def test_a_min_bound_on_an_infinite_margin_is_held_and_round_trips(tmp_path):
    """The example with GM ≥ 2 tunes to its own optimum, K = (1 + (ωτ)²)/(2τ) = 25.25 1/s
    (its description; 1e-6 relative: IPOPT's tolerance on a minimum where the radial error
    touches 0, as tests/reference/test_koren_1979.py), the bound reported as held."""
    spec = write(tmp_path, constraints=[{"metric": "gain_margin", "min": 2}])
    out = tmp_path / "result.json"
    done = run_cli("tune", str(spec), "-o", str(out), text=True)
    assert done.returncode == 0, done.stderr
    data = json.loads(out.read_text())
    assert data["metrics"]["gain_margin"]["value"] == "Infinity"
    assert data["constraints"][0] == {"metric": "gain_margin", "options": {}, "min": 2.0,
                                      "max": None, "value": "Infinity", "satisfied": True}
    assert re.search(r"^  gain_margin +inf \[1\]$", done.stderr, re.M), done.stderr
    assert "  gain_margin = inf [1]  (min 2)  OK" in done.stderr
    loaded = feedtune.load_result(out)
    assert loaded.data.metrics["gain_margin"].value == math.inf
    assert loaded.data.tuned["position_gain"].value == pytest.approx(25.25, rel=1e-6)
    gm = control.stability_margins(loaded.to_control().open_loop)[0]
    assert gm == loaded.data.metrics["gain_margin"].value == math.inf
    entry = next(e for e in data["validation"]["entries"] if e["metric"] == "gain_margin")
    assert entry["ok"] and entry["validated"] == "Infinity"


def test_the_report_draws_no_gain_margin_arrow(tmp_path):
    """The HTML's metric table shows "inf"; the Bode figure's note says ∞ (no GM arrow:
    tests/unit/test_report_margins.py checks the figure itself)."""
    out = tmp_path / "result.json"
    assert run_cli("tune", str(write(tmp_path)), "-o", str(out), "-q").returncode == 0
    done = run_cli("report", str(out), "--out", str(tmp_path / "report"), text=True)
    assert done.returncode == 0, done.stderr
    page = (tmp_path / "report" / "report.html").read_text()
    assert re.search(r"gain_margin</td><td[^>]*>inf</td>", page)


def test_maximising_an_infinite_margin_is_exit_2_at_its_pointer(tmp_path):
    spec = write(tmp_path, objective=[{"metric": "gain_margin", "goal": "maximize"}])
    for command in ("validate", "tune"):
        done = run_cli(command, str(spec), text=True)
        assert done.returncode == 2, done.stderr
        assert "/objective/0/metric" in done.stderr and "+∞" in done.stderr
