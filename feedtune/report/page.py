"""The report's HTML page: one self-contained file (figures as base64 data URIs, inline CSS)."""

from __future__ import annotations

import base64
import json
from html import escape

from feedtune import __version__
from feedtune.schema.labels import metric_label
from feedtune.schema.model import read_number

CSS = """body{font-family:sans-serif;max-width:60em;margin:2em auto;padding:0 1em;color:#222}
table{border-collapse:collapse;margin:0.5em 0 1.5em}td,th{border:1px solid #ccc;
padding:0.2em 0.6em;text-align:left;font-size:90%}th{background:#f3f3f3}
td.num{text-align:right;font-family:monospace}.bad{color:#b00;font-weight:bold}
.ok{color:#070}.note{color:#666;font-style:italic}img{max-width:100%;height:auto}
.scroll{overflow-x:auto}pre{white-space:pre-wrap;overflow-wrap:anywhere;background:#f7f7f7;
padding:0.5em;font-size:85%}td.about{min-width:18em}"""

#: provenance keys of a result, with what the page calls them
PROVENANCE = (("feedtune", "feedtune (tuned with)"), ("casadi", "CasADi"), ("ipopt", "IPOPT"),
              ("python", "Python"),
              ("spec_sha256", "SHA-256 of the canonical spec (sorted keys, defaults filled)"))


def _num(value) -> str:
    if value is None:
        return "—"
    if isinstance(value, str) and read_number(value) is not None:  # ±∞ as JSON carries it
        value = read_number(value)
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, list):  # poles: [[re, im], ...]
        return ", ".join(f"{re:.4g}{im:+.4g}j" for re, im in value)
    return str(value)


def _table(head: list[str], rows: list[list[str]]) -> str:
    """Cells are HTML already (escaped by the caller)."""
    out = ['<div class="scroll"><table><tr>'
           + "".join(f"<th>{escape(h)}</th>" for h in head) + "</tr>"]
    out += ["<tr>" + "".join(rows_cell for rows_cell in row) + "</tr>" for row in rows]
    return "\n".join(out) + "</table></div>"


def _td(text: str, cls: str = "") -> str:
    return f'<td class="{cls}">{escape(text)}</td>' if cls else f"<td>{escape(text)}</td>"


def tuned_table(result: dict) -> str:
    rows = []
    for name, t in (result.get("tuned") or {}).items():
        bound = "fixed" if t.get("fixed") else (f"at {t['at_bound']} bound"
                                                if t.get("at_bound") else "")
        rows.append([_td(name), _td(_num(t.get("value")), "num"), _td(t.get("unit", "")),
                     _td(f"[{_num(t.get('min'))}, {_num(t.get('max'))}]"), _td(bound)])
    return _table(["tunable", "value", "unit", "bounds", ""], rows)


def metrics_table(result: dict) -> str:
    rows = [[_td(metric_label(m["metric"], m.get("options"))), _td(_num(m.get("value")), "num"),
             _td(m.get("unit") or "")] for m in (result.get("metrics") or {}).values()]
    return _table(["metric", "value", "unit"], rows)


def constraints_table(result: dict) -> str:
    rows = []
    unstable = (result.get("stability") or {}).get("stable") is False
    for c in result.get("constraints") or []:
        ok = c.get("satisfied")
        rows.append([_td(metric_label(c["metric"], c.get("options"))), _td(_num(c.get("value")), "num"),
                     _td(_num(c.get("min")), "num"), _td(_num(c.get("max")), "num"),
                     _td("OK" if ok else "not met (loop unstable)" if unstable else "violated",
                         "ok" if ok else "bad")])
    return _table(["constraint", "value", "min", "max", ""], rows)


def findings(result: dict) -> str:
    """Plausibility warnings and a non-unique optimum, as the command line states them."""
    items = [f"<li>Implausible: {escape(w)}</li>" for w in result.get("warnings") or []]
    optimum = result.get("optimum") or {}
    if optimum.get("unique") is False:
        undecided = list(dict.fromkeys([*optimum.get("flat", []), *optimum.get("spread", {})]))
        items.append(f"<li>The optimum is not unique: the objective does not decide "
                     f"{escape(', '.join(undecided))}. {escape(optimum.get('advice') or '')}</li>")
    return f'<ul class="bad">{"".join(items)}</ul>' if items else ""


def validation_table(block: dict | None) -> str:
    if not block:
        return '<p class="note">This result has no validation block.</p>'
    if not block.get("covered"):
        reason = block.get("reason") or "not covered"
        error = f" ({block['error']})" if block.get("error") else ""
        return f'<p class="note">Not validated: {escape(reason + error)}.</p>'
    rows = []
    for e in block.get("entries") or []:
        ok = e.get("ok")
        unit = e.get("unit") or ""
        rows.append([_td(metric_label(e["metric"], e.get("options"))), _td(_num(e.get("reported")), "num"),
                     _td(_num(e.get("validated")), "num"), _td(unit),
                     _td("" if e.get("gap") is None else f"{e['gap']:.2g}", "num"),
                     _td("" if e.get("tolerance") is None else f"{e['tolerance']:.2g}", "num"),
                     _td(e.get("basis") or ""),
                     _td("OK" if ok else "beyond tolerance", "ok" if ok else "bad")])
    summary = ("every gap within its tolerance" if block.get("ok")
               else "some gaps beyond tolerance" if block.get("ok") is False else "nothing compared")
    return (f"<p>{escape(block.get('validator', ''))}: {escape(summary)}. A gap is "
            "|reported − re-measured| in the metric's unit, judged against the tolerance's "
            "physical scale (basis).</p>"
            + _table(["metric", "reported", "re-measured", "unit", "gap", "tolerance", "basis", ""],
                     rows))


def plant_table(result: dict, parameters: list[dict] | None) -> str:
    """The spec's plant block, one row per parameter with its unit and description from
    ``parameters`` (``name``, ``unit``, ``description`` each; None: units unknown)."""
    plant = (result.get("spec") or {}).get("plant") or {}
    if not plant:
        return '<p class="note">The result holds no plant block.</p>'
    known = {p["name"]: p for p in parameters or []}
    rows = []
    for name, value in plant.items():
        about = known.get(name, {})
        shown = value if isinstance(value, str) else json.dumps(value, ensure_ascii=False)
        rows.append([_td(name), _td(shown, "num"), _td(about.get("unit") or ""),
                     _td(about.get("description") or "", "about")])
    note = ("" if parameters is not None else
            '<p class="note">Parameter units unknown here; see <code>feedtune plants</code>.</p>')
    return _table(["parameter", "value", "unit", "meaning"], rows) + note


def provenance_table(result: dict) -> str:
    """Versions the result was tuned with, the spec's SHA-256, and this report's version."""
    provenance = result.get("provenance") or {}
    rows = [[_td(label), _td(str(provenance[key]) if provenance.get(key) is not None else "—")]
            for key, label in PROVENANCE]
    rows.append([_td("feedtune (this report)"), _td(__version__)])
    return _table(["", "version or digest"], rows)


def spec_block(result: dict) -> str:
    """The canonical spec as pretty JSON."""
    text = json.dumps(result.get("spec") or {}, indent=2, ensure_ascii=False)
    return f"<details open><summary>Spec (canonical JSON)</summary><pre>{escape(text)}</pre></details>"


def render(result: dict, figures: list[tuple[str, str, bytes | None, str | None]],
           parameters: list[dict] | None = None) -> str:
    """The page.

    Parameters
    ----------
    result : dict
        A result (JSON form).
    figures : list of tuple
        (stem, title, PNG bytes or None, note when omitted).
    parameters : list of dict, optional
        The plant's parameter descriptions for units (see :func:`plant_table`).
    """
    name = result.get("name") or "result"
    status = result.get("status", "")
    success = result.get("success")
    parts = ['<!DOCTYPE html><html lang="en"><head><meta charset="utf-8">'
             '<meta name="viewport" content="width=device-width, initial-scale=1">'
             f"<title>feedtune report: {escape(name)}</title><style>{CSS}</style></head><body>",
             f"<h1>{escape(name)}</h1>",
             f"<p>Status: <b class=\"{'ok' if success else 'bad'}\">{escape(str(status))}</b>"
             f" — {escape(result.get('message') or '')}; objective "
             f"{escape(_num(result.get('objective')))}.</p>"]
    plant = ((result.get("spec") or {}).get("plant") or {}).get("type")
    if plant:
        parts.append(f"<p>Plant: <code>{escape(str(plant))}</code>.</p>")
    parts.append(findings(result))
    parts.append("<h2>Tuned values</h2>" + tuned_table(result))
    for stem, title, png, note in figures:
        parts.append(f"<h2>{escape(title)}</h2>")
        if png is None:
            parts.append(f'<p class="note">Not drawn: {escape(note or "")}.</p>')
        else:
            data = base64.b64encode(png).decode("ascii")
            parts.append(f'<img alt="{escape(title)}" src="data:image/png;base64,{data}">'
                         f'<p class="note">{escape(stem)}.png</p>')
    parts.append("<h2>Metrics</h2>" + metrics_table(result))
    if result.get("constraints"):
        parts.append("<h2>Constraints</h2>" + constraints_table(result))
    parts.append("<h2>Independent validation</h2>" + validation_table(result.get("validation")))
    parts.append("<h2>Plant parameters</h2>" + plant_table(result, parameters))
    parts.append("<h2>Provenance</h2>" + provenance_table(result))
    parts.append("<h2>Spec</h2>" + spec_block(result))
    parts.append("</body></html>")
    return "\n".join(parts)
