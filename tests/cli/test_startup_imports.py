"""What the quick commands load (issue 15: `feedtune --help` and `feedtune validate` start in
under 0.3 s; benchmarks/startup.py measures the time). These tests hold the import set, not
the time: each command runs through the real entry point (``feedtune.__main__.main``) in a
fresh interpreter, which then lists the heavy packages it holds in ``sys.modules``."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
EXAMPLES = sorted((REPO / "examples").glob("*.json"))

#: run ``feedtune ARGS`` in this interpreter, then print the loaded heavy packages on stderr
_PROBE = """
import json, sys
args, packages = json.loads(sys.argv[1]), json.loads(sys.argv[2])
sys.argv = ["feedtune", *args]
from feedtune.__main__ import main
try:
    main()
except SystemExit as exc:
    status = exc.code
heavy = [package for package in packages
         if any(name == package or name.startswith(package + ".") for name in sys.modules)]
print("\\nloaded: " + json.dumps({"status": status, "heavy": heavy}), file=sys.stderr)
"""


def loaded(args: list[str], packages: tuple[str, ...]) -> tuple[int, list[str]]:
    """(exit status, which of ``packages`` (or their submodules) are in sys.modules) after
    ``feedtune ARGS``."""
    proc = subprocess.run([sys.executable, "-c", _PROBE, json.dumps(args), json.dumps(packages)],
                          capture_output=True, text=True, cwd=REPO, timeout=120, check=True)
    report = json.loads(proc.stderr.rsplit("loaded: ", 1)[1])
    return report["status"], report["heavy"]


def test_help_loads_no_spec_model_or_numerical_package():
    status, heavy = loaded(["--help"], ("pydantic", "numpy", "casadi", "scipy", "matplotlib"))
    assert status == 0
    assert heavy == []


@pytest.mark.parametrize("example", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_validate_loads_neither_scipy_nor_matplotlib(example):
    status, heavy = loaded(["validate", str(example)], ("scipy", "matplotlib", "feedtune.tuner"))
    assert status == 0
    assert heavy == []


@pytest.mark.xfail(strict=True, reason=(
    "validate builds each spec's CasADi loop for the registry checks, and feedtune.loop, "
    "feedtune.linalg, feedtune.signals, feedtune.frequency, the plant modules and most metric "
    "modules import casadi at their top; see benchmarks/README.md"))
def test_validate_loads_no_casadi():
    status, heavy = loaded(["validate", str(REPO / "examples" / "koren-1979-sampled-data.json")],
                           ("casadi",))
    assert status == 0
    assert heavy == []
