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


#: what every child of :func:`numbers_side_by_side` starts with: one BLAS thread (as the
#: ``feedtune`` command), the contract tests' cases importable as ``cc``
CHILD_HEAD = r"""
import json, sys, time
sys.path.insert(0, {contract!r})
from feedtune.__main__ import pin_blas_threads
pin_blas_threads()
import contract_cases as cc
"""


def numbers_side_by_side(child: str, revision: str, rounds: int, **fields) -> None:
    """Run ``child`` (Python source after :data:`CHILD_HEAD`, formatted with ``fields``;
    it prints one JSON line {"cpu": s, "values": [floats]}) with
    ``revision``'s package and with this checkout's, in turn, ``rounds`` times; print the
    CPU of each per round, the ratio, how many numbers are the same bits and the largest
    difference relative to max(|value|, 1)."""
    import json
    import os

    old_tree = export_package(revision, Path(tempfile.mkdtemp(prefix="feedtune-baseline-")))
    trees = {short_revision(revision): old_tree, "new": REPO}
    code = (CHILD_HEAD + child).format(contract=str(REPO / "tests" / "contract"), **fields)

    def run(tree: Path) -> dict:
        out = subprocess.run([sys.executable, "-c", code], cwd=tempfile.gettempdir(),
                             env={**os.environ, "PYTHONPATH": str(tree)},
                             capture_output=True, text=True, check=True).stdout
        return json.loads(out.strip().splitlines()[-1])

    cpu = {label: [] for label in trees}
    worst, same = 0.0, 0
    for _ in range(rounds):
        results = {label: run(tree) for label, tree in trees.items()}
        for label, result in results.items():
            cpu[label].append(result["cpu"])
        old, new = (results[label]["values"] for label in trees)
        assert len(old) == len(new)
        worst = max(worst, max(abs(a - b) / max(abs(a), 1.0) for a, b in zip(old, new)))
        same = sum(a == b or (a != a and b != b) for a, b in zip(old, new))
    (old_label, old_cpu), (_, new_cpu) = cpu.items()
    print(f"{len(old)} numbers per round; CPU s per round: {old_label} "
          f"{', '.join(f'{c:.2f}' for c in old_cpu)}; new {', '.join(f'{c:.2f}' for c in new_cpu)}")
    print(f"new/{old_label} {sum(new_cpu) / sum(old_cpu):.3f}; largest difference {worst:.1e}; "
          f"{same} of {len(old)} the same bits")
