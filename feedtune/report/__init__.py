"""Plots and a self-contained HTML report of a tuned result (``feedtune report``).

Everything drawn comes from the result JSON and the independent validator model of its
plant (:mod:`feedtune.validate.models`); a figure the plant cannot offer is left out with
the reason on the page.
"""

from __future__ import annotations

import io
from pathlib import Path

from feedtune.report import frequency_data
from feedtune.report.figures import FIGURES
from feedtune.report.output import ReportDirError, write_files
from feedtune.report.output import check_out_dir as check
from feedtune.report.page import render
from feedtune.validate.model import NotCovered
from feedtune.validate.models import model_for

__all__ = ["NAMES", "ReportDirError", "build_figures", "check_out_dir", "write_report"]


def _png(figure) -> bytes:
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", metadata={"Software": None})
    return buffer.getvalue()


def build_figures(result: dict) -> list[tuple[str, str, bytes | None, str | None]]:
    """(stem, title, PNG bytes or None, why not) for every figure of the report; a result
    tuned on measured data has its own (:data:`MEASURED`)."""
    kind = ((result.get("spec") or {}).get("plant") or {}).get("type")
    if kind in MEASURED:
        return MEASURED[kind](result, _png)
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


#: plants known only by measured data: plant type → their figures (no validator model)
MEASURED = {"frequency_response_data": frequency_data.figures_of}

#: every file a report may write into its directory, the page first
NAMES = ["report.html"] + [f"{stem}.png" for stem, _, _ in FIGURES + frequency_data.FIGURES]


def check_out_dir(out_dir: Path) -> None:
    """Raise :class:`ReportDirError` naming every file of ``out_dir`` the report would
    replace or delete but did not write (see :mod:`feedtune.report.output`)."""
    check(out_dir, NAMES)


def write_report(result: dict, out_dir: Path, figures: list | None = None,
                 parameters: list[dict] | None = None) -> list[Path]:
    """Write ``report.html`` and one PNG per drawn figure into ``out_dir`` (created).

    Parameters
    ----------
    result : dict
        A result of ``feedtune tune`` (JSON form).
    out_dir : Path
        The report directory; files of other names in it are left alone.
    figures : list, optional
        From :func:`build_figures` (drawn here when omitted).
    parameters : list of dict, optional
        The plant's parameter descriptions (``name``, ``unit``, ``description``, as
        ``feedtune plants --json`` lists them), for the units on the page.

    Returns
    -------
    list of Path
        The files written, the page first.

    Raises
    ------
    ReportDirError
        ``out_dir`` holds a file of a name the report writes that it did not write; nothing
        is written then.
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    check(out_dir, NAMES)  # before the slow drawing
    if figures is None:
        figures = build_figures(result)
    files = {"report.html": render(result, figures, parameters).encode("utf-8")}
    files.update((f"{stem}.png", png) for stem, _, png, _ in figures if png is not None)
    write_files(out_dir, files, NAMES)
    return [out_dir / name for name in files]
