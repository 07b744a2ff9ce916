"""Plots and a self-contained HTML report of a tuned result (``feedtune report``).

Everything drawn comes from the result JSON and the independent validator model of its
plant (:mod:`feedtune.validate.models`); a figure the plant cannot offer is left out with
the reason on the page.
"""

from __future__ import annotations

import io
from pathlib import Path

from feedtune.files import write_atomic
from feedtune.report.figures import FIGURES
from feedtune.report.page import render
from feedtune.validate.model import NotCovered
from feedtune.validate.models import model_for


def _png(figure) -> bytes:
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", metadata={"Software": None})
    return buffer.getvalue()


def build_figures(result: dict) -> list[tuple[str, str, bytes | None, str | None]]:
    """(stem, title, PNG bytes or None, why not) for every figure of the report."""
    tuned = {name: t["value"] for name, t in (result.get("tuned") or {}).items()}
    model, why = None, None
    if not tuned:
        why = "nothing was tuned"
    else:
        try:
            model = model_for((result.get("spec") or {}).get("plant") or {}, tuned,
                              result.get("stability"))
        except NotCovered as exc:
            why = str(exc)
    figures = []
    for stem, title, draw in FIGURES:
        if model is None:
            figures.append((stem, title, None, why))
            continue
        try:
            figures.append((stem, title, _png(draw(model, result)), None))
        except NotCovered as exc:
            figures.append((stem, title, None, str(exc)))
        except ValueError as exc:  # an unstable loop never settles; LinAlgError included
            figures.append((stem, title, None, f"{type(exc).__name__}: {exc}"))
    return figures


def write_report(result: dict, out_dir: Path, figures: list | None = None) -> list[Path]:
    """Write ``report.html`` and one PNG per drawn figure into ``out_dir`` (created);
    returns the paths written, the page first. ``figures``: from :func:`build_figures`
    (drawn here when omitted)."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    if figures is None:
        figures = build_figures(result)
    written = [out_dir / "report.html"]
    for stem, _, png, _ in figures:
        if png is not None:
            write_atomic(out_dir / f"{stem}.png", png)
            written.append(out_dir / f"{stem}.png")
        else:  # a figure of an earlier report of this directory would now be stale
            (out_dir / f"{stem}.png").unlink(missing_ok=True)
    write_atomic(written[0], render(result, figures).encode("utf-8"))
    return written
