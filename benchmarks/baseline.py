"""The ``feedtune`` package of an older git revision, for the benchmarks' side-by-side runs."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def export_package(revision: str, into: Path) -> Path:
    """Unpack ``revision``'s ``feedtune/`` under ``into`` (``git archive``: nothing in the
    work tree changes) and return ``into``, to put first on a child's PYTHONPATH."""
    archive = subprocess.run(["git", "-C", str(REPO), "archive", revision, "feedtune"],
                             capture_output=True, check=True).stdout
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    return into


def short_revision(revision: str) -> str:
    """``git rev-parse --short revision``."""
    return subprocess.run(["git", "-C", str(REPO), "rev-parse", "--short", revision],
                          check=True, capture_output=True, text=True).stdout.strip()


def baseline_module(revision: str, path: str, name: str):
    """``revision``'s module at ``path`` (e.g. ``feedtune/validate/linear.py``) loaded as
    ``name``, beside this checkout's: what it imports from feedtune it shares with the
    checkout, so only the one file's code is the baseline's."""
    text = subprocess.run(["git", "-C", str(REPO), "show", f"{revision}:{path}"],
                          capture_output=True, text=True, check=True).stdout
    file = Path(tempfile.mkdtemp()) / f"{name}.py"
    file.write_text(text)
    spec = importlib.util.spec_from_file_location(name, file)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # dataclasses look their module up while it loads
    spec.loader.exec_module(module)
    return module
