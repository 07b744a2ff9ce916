"""The identification report: data against model, one figure per data set, and a page.

Drawn like ``feedtune report`` (its figure size, resolution, page style and the same
manifest that keeps a report from overwriting files it did not write).
"""

from __future__ import annotations

import base64
import io
import json
from html import escape
from pathlib import Path

import numpy as np

from feedtune.measured.data import FrequencyResponseData
from feedtune.measured.fit import model_output
from feedtune.report.figures import _figure
from feedtune.report.output import ReportDirError, check_out_dir, write_files
from feedtune.report.page import CSS, _num, _table, _td

PAGE = "identification.html"

__all__ = ["ReportDirError", "write_identification_report"]


def _names(count: int) -> list[str]:
    return [PAGE] + [f"data-{i + 1}.png" for i in range(count)]


def data_figure(identification, index: int):
    """Data set ``index`` against the model: Bode magnitude [output/input] and phase [deg]
    against ω [rad/s], or the output and the model's against time [s]."""
    d = identification.data[index]
    fitted = model_output(identification.fit.model, d, identification.fit.offsets[index])
    nrmse = identification.fit.nrmse[index]
    unit = f"{d.output_unit}/{d.input_unit}"
    if isinstance(d, FrequencyResponseData):
        figure, axes = _figure(2, 1)
        mag, phase = axes[0][0], axes[1][0]
        w = d.frequency_rad_s
        mag.loglog(w, np.abs(d.response), ".", ms=3, label="data")
        mag.loglog(w, np.abs(fitted), "-", label="model")
        phase.semilogx(w, np.degrees(np.unwrap(np.angle(d.response))), ".", ms=3)
        phase.semilogx(w, np.degrees(np.unwrap(np.angle(fitted))), "-")
        mag.set_ylabel(f"|G| [{unit}]")
        phase.set_ylabel("phase [deg]")
        phase.set_xlabel("ω [rad/s]")
        mag.legend(loc="lower left")
        mag.set_title(f"{Path(d.source).name}: NRMSE {nrmse:.3g}")
    else:
        figure, axes = _figure(2, 1)
        top, bottom = axes[0][0], axes[1][0]
        top.plot(d.time_s, d.output, ".", ms=2, label="data")
        top.plot(d.time_s, fitted, "-", label="model")
        bottom.plot(d.time_s, d.output - fitted, "-", lw=0.6)
        top.set_ylabel(f"{d.output_kind} [{d.output_unit}]")
        bottom.set_ylabel(f"data − model [{d.output_unit}]")
        bottom.set_xlabel("time [s]")
        top.legend(loc="best")
        top.set_title(f"{Path(d.source).name}: NRMSE {nrmse:.3g}")
    figure.tight_layout()
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", metadata={"Software": None})
    return buffer.getvalue()


def render(identification, pngs: list[bytes]) -> str:
    """The page: parameters with units and standard errors, data sets, figures, plant block."""
    doc = identification.to_dict()
    rows = [[_td(name), _td(_num(p["value"]), "num"), _td(_num(p["standard_error"]), "num"),
             _td(p["unit"]), _td(p["description"], "about")]
            for name, p in doc["parameters"].items()]
    data_rows = [[_td(e["source"]), _td(e["kind"]), _td(e["output"]), _td(str(e["points"])),
                  _td(_num(e["nrmse"]), "num")] for e in doc["data"]]
    parts = ['<!DOCTYPE html><html lang="en"><head><meta charset="utf-8">'
             f"<title>feedtune identify: {escape(doc['model'])}</title><style>{CSS}</style>"
             f"</head><body><h1>Identified {escape(doc['model'])}</h1>",
             f"<p>{escape(doc['fit']['method'])}.</p>",
             "<h2>Parameters</h2>" + _table(["parameter", "value", "standard error", "unit",
                                             "description"], rows),
             f'<p class="note">{escape(doc["fit"]["uncertainty"])}.</p>',
             f"<p>{escape(doc['lumped'])}</p>",
             "<h2>Data</h2>" + _table(["file", "kind", "output", "points", "NRMSE"], data_rows)]
    for i, png in enumerate(pngs):
        data = base64.b64encode(png).decode("ascii")
        parts.append(f'<img alt="data set {i + 1}" src="data:image/png;base64,{data}">'
                     f'<p class="note">data-{i + 1}.png</p>')
    parts.append("<h2>Plant block</h2><pre>" + escape(json.dumps(doc["plant"], indent=2))
                 + "</pre></body></html>")
    return "\n".join(parts)


def write_identification_report(identification, out_dir: Path) -> Path:
    """Write the page and the figures into ``out_dir`` (created); the page's path.

    Raises
    ------
    ReportDirError
        A file of the report's names in ``out_dir`` that an earlier report did not write.
    """
    names = _names(len(identification.data))
    out_dir = Path(out_dir)
    if out_dir.is_dir():
        check_out_dir(out_dir, names)
    pngs = [data_figure(identification, i) for i in range(len(identification.data))]
    files = {PAGE: render(identification, pngs).encode("utf-8")}
    files.update({f"data-{i + 1}.png": png for i, png in enumerate(pngs)})
    out_dir.mkdir(exist_ok=True)
    write_files(out_dir, files, names)
    return out_dir / PAGE
