"""The ``validation`` block of a result: each metric as the optimiser reported it, as the
independent numpy/scipy model re-measured it, and the gap judged on the metric's physical
scale (:mod:`feedtune.validate.tolerances`).

Each plant type has its model in :mod:`feedtune.validate.models`; a plant without one is
``covered: false`` with the reason. Each model declares the metrics it measures as tables
(:mod:`feedtune.validate.measurements`); a metric no table measures is not listed, and the
contract test fails for it unless it is exempt there with a reason.
The result is taken as a plain dict (``TuneResult.model_dump()``), so that this module
never imports CasADi (tests/architecture).
"""

from __future__ import annotations

from feedtune.schema.labels import metric_label
from feedtune.schema.uncertainty import with_numbers
from feedtune.validate.entries import poles_entry, stable_entry
from feedtune.validate.measurements import Phase, measures
from feedtune.validate.model import NotCovered
from feedtune.validate.models import model_for
from feedtune.validate.poles import POLE_MEASUREMENTS, pole_entries


#: the fields of a result that no validator reads, left out of its dump: the solver's
#: record of every start is most of a batch result (a dump without them takes a third of
#: the time, and the fields read are the same)
UNREAD = frozenset({"solver", "optimum", "provenance", "warnings", "validation"})


def _measured_entries(result: dict) -> list[dict]:
    """:func:`feedtune.validate.frequency_data.validate_measured`, its module (and
    scipy.interpolate, ≈ 0.1 s of imports) imported when a result of measured data is
    validated, not by every tuning (issue 15's start-up)."""
    from feedtune.validate.frequency_data import validate_measured

    return validate_measured(result)


#: plants known only by measured data: plant type → (validator, its entries from a result)
MEASURED = {"frequency_response_data": (
    "numpy/scipy re-evaluation on every measured frequency (feedtune.validate.frequency_data)",
    _measured_entries)}


def measurement_phases(model) -> tuple[Phase, ...]:
    """Every table ``model`` is measured with: its own (``measurement_tables()``), then the
    pole measures (:data:`feedtune.validate.poles.POLE_MEASUREMENTS`)."""
    return tuple(model.measurement_tables()) + (Phase(POLE_MEASUREMENTS),)


def is_measured(model, metric: str, options: dict) -> bool:
    """Whether the validator declares a measurement of ``metric`` with ``options`` (a
    result's options dict) on ``model``; tests/contract/test_validator_contract.py asks it
    of every metric every loop reports."""
    return measures(measurement_phases(model), metric, options, model)


def _measure(model, result: dict) -> list[dict]:
    """The model's own entries, the pole measures (:mod:`feedtune.validate.poles`), then the
    closed-loop poles and stability where the model has them."""
    entries = model.measure(result) + pole_entries(model, result)
    stability = result.get("stability") or {}
    try:
        if stability.get("poles"):
            entries.append(poles_entry(stability["poles"], model.poles(), model.sampled))
    except NotCovered:
        pass
    try:
        if "stable" in stability:
            entries.append(stable_entry(stability["stable"], model.stable()))
    except NotCovered:
        pass
    return entries


def validate_result(result) -> dict:
    """The validation block of ``result`` (a TuneResult or its dict); never raises.

    No wall time in it: a result is the same bytes whoever solves it (batch executors,
    stdin/file); the re-simulation takes 3–50 ms on Koren's, Sato's and Tian's examples and
    ≈ 0.04 s on Bhatia's and Ward-Leonard's (one BLAS thread; benchmarks/README.md).

    ``{"validator", "covered", "reason", "ok", "entries": [{"metric", "options",
    "reported", "validated", "unit", "gap", "tolerance", "basis", "ok"}, ...]}`` (gap and
    tolerance in ``unit``, ``basis`` the scale that set the tolerance); ``ok`` is None when
    nothing was validated (a plant not covered, a failed tuning), else whether every entry
    is within its tolerance. A validator failure is a block with ``error``.
    """
    data = (result.model_dump(mode="json", exclude=UNREAD) if hasattr(result, "model_dump")
            else result)
    block = {"validator": "numpy/scipy re-simulation (feedtune.validate)", "covered": False,
             "reason": None, "ok": None, "entries": []}
    try:
        if not data.get("tuned"):
            block["reason"] = "nothing tuned to validate"
        else:
            plant = (data.get("spec") or {}).get("plant") or {}
            tuned = {name: t["value"] for name, t in data["tuned"].items()}
            if plant.get("type") in MEASURED:  # no model: the data themselves
                block["validator"], measure = MEASURED[plant["type"]]
                block["entries"] = measure(data)
            else:
                model = model_for(plant, tuned, data.get("stability"))
                block["entries"] = _measure(model, data)
            block["covered"] = True
            checked = list(block["entries"])
            if data.get("robust"):
                block["scenarios"], block["worst_cases"] = _robust_checks(data, plant, tuned)
                checked += [e for check in block["scenarios"] + block["worst_cases"]
                            for e in check["entries"]]
            block["ok"] = all(e["ok"] for e in checked) if checked else None
    except NotCovered as exc:
        block["reason"] = str(exc)
    except Exception as exc:  # noqa: BLE001 — validation must never break a tuning
        block["reason"] = "validator error"
        block["error"] = f"{type(exc).__name__}: {exc}"
        block["entries"] = []
    return block


def _constraint_records(constraints: list[dict], values: list, units: dict) -> dict:
    """A result's ``metrics`` block for the spec's ``constraints`` with these ``values``
    (the form :func:`_measure` reads), each with the unit the result reports for it."""
    records = {}
    for i, (constraint, value) in enumerate(zip(constraints, values)):
        options = {k: v for k, v in constraint.items() if k not in ("metric", "min", "max")}
        records[str(i)] = {"metric": constraint["metric"], "options": options, "value": value,
                           "unit": units.get(constraint["metric"])}
    return records


def _robust_checks(data: dict, plant: dict, tuned: dict) -> tuple[list[dict], list[dict]]:
    """Every scenario of a robust result, and every constraint's worst case, re-measured
    on the validator's own model of the plant with those numbers: the constraints as the
    tuner reported them there and the stability verdict (feedtune.robust). A pulse
    generator's scenarios are simulated over the nominal loop's horizon (the result's
    stability block)."""
    robust, constraints = data["robust"], (data.get("spec") or {}).get("constraints") or []
    units = {m["metric"]: m.get("unit") for m in (data.get("metrics") or {}).values()}
    scenarios = []
    for scenario in robust.get("scenarios") or []:
        model = model_for(with_numbers(plant, scenario["parameters"]), tuned, data.get("stability"))
        view = {**data, "metrics": _constraint_records(constraints, scenario["constraints"], units),
                "stability": {"stable": scenario["stable"]}}
        entries = _measure(model, view)
        scenarios.append({"parameters": scenario["parameters"], "entries": entries,
                          "ok": all(e["ok"] for e in entries)})
    worst = []
    for i, case in enumerate(robust.get("worst_cases") or []):
        model = model_for(with_numbers(plant, case["parameters"]), tuned, data.get("stability"))
        values = [None] * len(constraints)
        values[i] = case["value"]
        view = {**data, "metrics": _constraint_records(constraints, values, units),
                "stability": {}}
        entries = model.measure(view)
        worst.append({"metric": case["metric"], "parameters": case["parameters"],
                      "entries": entries, "ok": all(e["ok"] for e in entries)})
    return scenarios, worst


def failures(block: dict | None) -> list[dict]:
    """The entries of ``block`` outside their tolerance, a robust result's scenarios and
    worst cases included."""
    if not block:
        return []
    checks = block.get("scenarios", []) + block.get("worst_cases", [])
    return [e for e in block.get("entries", []) + [e for c in checks for e in c["entries"]]
            if e.get("ok") is False]


def _fmt(value) -> str:
    if isinstance(value, float):
        return f"{value:.6g}"
    return str(value)


def warning_lines(block: dict | None) -> list[str]:
    """``warning: validation: METRIC reported X, re-simulated Y, gap G m > tolerance T m
    (BLU/1000)``: one line per entry outside its tolerance, judged once by
    :func:`feedtune.validate.tolerances.judge` (``feedtune batch`` fails the same entries)."""
    lines = []
    for e in failures(block):
        label = metric_label(e["metric"], e["options"])
        text = (f"warning: validation: {label} reported {_fmt(e['reported'])}, "
                f"re-simulated {_fmt(e['validated'])}")
        if e["gap"] is not None:
            unit = f" {e['unit']}" if e.get("unit") not in (None, "1") else ""
            basis = f" ({e['basis']})" if e.get("basis") else ""
            text += f", gap {e['gap']:.3g}{unit} > tolerance {e['tolerance']:.3g}{unit}{basis}"
        lines.append(text)
    if block and block.get("error"):
        lines.append(f"warning: validation: the validator failed: {block['error']}")
    return lines
