"""The report's figures (``feedtune/report/figures.py``), this checkout's against a git
revision's, side by side in one process (issue 15: ``feedtune report``, ``tune --report``,
``Result.report`` and their tests).

For each stored result of tests/data/ (or those named), the validator model is built once
(:func:`feedtune.validate.models.model_for`, shared by both) and every figure is drawn and
written as the report writes it (``feedtune.report._png``) by the new module and the
baseline's in turn, ``--rounds`` times; printed per figure: the median CPU [ms] of each,
their ratio, and whether the PNG bytes are equal.

    .venv/bin/python benchmarks/report_figures.py [--baseline main] [--rounds 5] [RESULT ...]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

from baseline import baseline_module, short_revision

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from feedtune.report import _png  # noqa: E402
from feedtune.report import figures as new  # noqa: E402
from feedtune.validate.model import NotCovered  # noqa: E402
from feedtune.validate.models import model_for  # noqa: E402


def _draw(module, stem: str, model, result: dict) -> tuple[float, bytes | None]:
    """(CPU [s], PNG bytes or None) of figure ``stem`` drawn by ``module``."""
    draw = {s: f for s, _, f in module.FIGURES}[stem]
    start = time.process_time()
    try:
        png = _png(draw(model, result))
    except NotCovered:
        png = None
    return time.process_time() - start, png


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("results", nargs="*", type=Path,
                        default=sorted((REPO / "tests" / "data").glob("*.result.json")))
    parser.add_argument("--baseline", default="main")
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    old = baseline_module(args.baseline, "feedtune/report/figures.py", "baseline_figures")
    print(f"baseline {args.baseline} ({short_revision(args.baseline)}), {args.rounds} rounds; "
          "CPU ms per figure, medians")
    print(f"{'result':38} {'figure':10} {'baseline':>9} {'new':>9} {'ratio':>6}  same PNG")
    totals = {"baseline": 0.0, "new": 0.0}
    for path in args.results:
        result = json.loads(path.read_text(encoding="utf-8"))
        tuned = {name: t["value"] for name, t in result["tuned"].items()}
        model = model_for(result["spec"]["plant"], tuned, result.get("stability"))
        for stem, _, _ in new.FIGURES:
            _draw(new, stem, model, result)  # the model's own caches, and matplotlib's
            times = {"baseline": [], "new": []}
            pngs = {}
            for _ in range(args.rounds):
                for label, module in (("baseline", old), ("new", new)):
                    cpu, pngs[label] = _draw(module, stem, model, result)
                    times[label].append(cpu)
            if pngs["new"] is None:
                continue
            medians = {k: statistics.median(v) for k, v in times.items()}
            for k, v in medians.items():
                totals[k] += v
            print(f"{path.name[:38]:38} {stem:10} {1e3 * medians['baseline']:9.1f} "
                  f"{1e3 * medians['new']:9.1f} {medians['new'] / medians['baseline']:6.2f}  "
                  f"{pngs['new'] == pngs['baseline']}")
    print(f"{'all':49} {1e3 * totals['baseline']:9.1f} {1e3 * totals['new']:9.1f} "
          f"{totals['new'] / totals['baseline']:6.2f}")


if __name__ == "__main__":
    main()
