"""The ``validation`` block of a result: each metric as the optimiser reported it, as the
independent numpy/scipy model re-measured it, and the relative gap.

Only :mod:`feedtune.validate.software_servo` exists so far: other plants, and the metrics
that model does not measure, are not listed (the block says which plant is not covered).
The result is taken as a plain dict (``TuneResult.model_dump()``), so that this module
never imports CasADi (tests/architecture).
"""

from __future__ import annotations

import numpy as np

from feedtune.validate.software_servo import NotCovered, ServoModel, average_polygon_radius

#: relative tolerance of each metric's gap, and why:
TOLERANCES = {
    # step integrals: the validator's trapezoid on ≥ 256 sub-steps per sample/block has a
    # relative error ~(h·ω)²/12 ≤ 1e-6 on the loops of the examples (measured 4e-8 … 3e-7)
    "iae": 1e-4, "ise": 1e-4, "itae": 1e-4,
    # eigenvalues/closed forms on both sides: only rounding separates them (~1e-12)
    "damping_ratio": 1e-6, "natural_frequency": 1e-6, "velocity_constant": 1e-6,
    "radial_error": 1e-6, "poles": 1e-6,
    # closed forms (Sato eqs 3, 7) on both sides
    "radius_decrease": 1e-6, "average_radius": 1e-9,
}
#: radial errors below this fraction of the radius count as zero (|H| = 1 to rounding)
RADIAL_FLOOR = 1e-8


def relative_gap(reported: float, validated: float, floor: float = 0.0) -> float:
    """|validated − reported| / max(|reported|, |validated|, floor)."""
    scale = max(abs(reported), abs(validated), floor)
    return 0.0 if scale == 0 else abs(validated - reported) / scale


def _entry(metric, options, reported, validated, floor=0.0):
    tolerance = TOLERANCES[metric]
    gap = relative_gap(reported, validated, floor)
    return {"metric": metric, "options": options, "reported": reported, "validated": validated,
            "gap": gap, "tolerance": tolerance, "ok": bool(gap <= tolerance)}


def _pole_gap(reported: list, validated: np.ndarray, discrete: bool) -> float:
    """Largest distance from a validated pole to the nearest reported one, relative to 1
    (z-plane) or to the pole's magnitude (s-plane); different counts are a gap of 1 (only
    zero poles may differ, from a different state choice)."""
    rep = np.array([complex(re, im) for re, im in reported])
    val = np.asarray(validated, dtype=complex)
    if discrete:  # z = 0 poles depend on how the delay buffer is written down
        rep, val = rep[np.abs(rep) > 1e-12], val[np.abs(val) > 1e-12]
    if len(rep) != len(val):
        return 1.0
    if len(val) == 0:
        return 0.0
    gaps = [np.min(np.abs(rep - v)) / (1.0 if discrete else max(abs(v), 1e-300)) for v in val]
    return float(max(gaps))


def _measure(model: ServoModel, result: dict) -> list[dict]:
    entries = []
    tuned = {name: t["value"] for name, t in result.get("tuned", {}).items()}
    zeta = wn = None
    try:
        zeta, wn = model.equivalent_pair()
    except NotCovered:
        pass
    integrals = None
    for key, m in result.get("metrics", {}).items():
        name, options, reported = m["metric"], m.get("options") or {}, m.get("value")
        if reported is None:
            continue
        if name in ("iae", "ise", "itae") and options.get("input", "step") == "step":
            if integrals is None:
                integrals = model.error_integrals()
            value = integrals[name]
            if options.get("time", "absolute") == "natural":
                if wn is None:
                    continue
                value *= wn ** {"iae": 1, "ise": 1, "itae": 2}[name]
            entries.append(_entry(name, options, reported, value))
        elif name == "damping_ratio" and zeta is not None:
            entries.append(_entry(name, options, reported, zeta))
        elif name == "natural_frequency" and wn is not None:
            entries.append(_entry(name, options, reported, wn))
        elif name == "velocity_constant":
            entries.append(_entry(name, options, reported, 1.0 / model.ramp_following_error()))
        elif name == "radial_error" and "radius" in options and "feed" in options:
            entries.append(_entry(name, options, reported,
                                  model.radial_error(options["radius"], options["feed"]),
                                  floor=RADIAL_FLOOR * options["radius"]))
        elif name in ("radius_decrease", "average_radius") and "reference_interval" in tuned:
            omega, interval = options["feed"] / options["radius"], tuned["reference_interval"]
            value = (average_polygon_radius(options["radius"], omega, interval)
                     if name == "average_radius" else
                     model.radius_decrease(options["radius"], options["feed"], interval))
            entries.append(_entry(name, options, reported, value,
                                  floor=RADIAL_FLOOR * options["radius"]))
    stability = result.get("stability") or {}
    if stability.get("poles"):
        poles = model.poles()
        gap = _pole_gap(stability["poles"], poles, model.sampled)
        entries.append({"metric": "poles", "options": {"domain": "z" if model.sampled else "s"},
                        "reported": stability["poles"],
                        "validated": [[float(p.real), float(p.imag)]
                                      for p in poles[np.lexsort((poles.imag, poles.real))]],
                        "gap": gap, "tolerance": TOLERANCES["poles"],
                        "ok": bool(gap <= TOLERANCES["poles"])})
    if "stable" in stability:
        validated = model.stable()
        entries.append({"metric": "stable", "options": {}, "reported": bool(stability["stable"]),
                        "validated": validated, "gap": None, "tolerance": None,
                        "ok": validated == bool(stability["stable"])})
    return entries


def validate_result(result) -> dict:
    """The validation block of ``result`` (a TuneResult or its dict); never raises.

    No wall time in it: a result is the same bytes whoever solves it (batch executors,
    stdin/file); the re-simulation takes 2–15 ms on Koren's and Sato's examples.

    ``{"validator", "covered", "reason", "ok", "entries": [{"metric", "options",
    "reported", "validated", "gap", "tolerance", "ok"}, ...]}``; ``ok`` is None when
    nothing was validated (a plant not covered, a failed tuning), else whether every entry
    is within its tolerance. A validator failure is a block with ``error``.
    """
    data = result.model_dump(mode="json") if hasattr(result, "model_dump") else result
    block = {"validator": "numpy/scipy re-simulation (feedtune.validate)", "covered": False,
             "reason": None, "ok": None, "entries": []}
    try:
        if not data.get("tuned"):
            block["reason"] = "nothing tuned to validate"
        else:
            plant = (data.get("spec") or {}).get("plant") or {}
            tuned = {name: t["value"] for name, t in data["tuned"].items()}
            model = ServoModel.from_result(plant, tuned)
            block["entries"] = _measure(model, data)
            block["covered"] = True
            block["ok"] = all(e["ok"] for e in block["entries"]) if block["entries"] else None
    except NotCovered as exc:
        block["reason"] = str(exc)
    except Exception as exc:  # noqa: BLE001 — validation must never break a tuning
        block["reason"] = "validator error"
        block["error"] = f"{type(exc).__name__}: {exc}"
        block["entries"] = []
    return block


def failures(block: dict | None) -> list[dict]:
    """The entries of ``block`` outside their tolerance."""
    if not block:
        return []
    return [e for e in block.get("entries", []) if e.get("ok") is False]


def _fmt(value) -> str:
    if isinstance(value, float):
        return f"{value:.6g}"
    return str(value)


def warning_lines(block: dict | None) -> list[str]:
    """``warning: validation: METRIC reported X, re-simulated Y, gap G > tolerance T``."""
    lines = []
    for e in failures(block):
        if e["gap"] is None:
            lines.append(f"warning: validation: {e['metric']} reported {_fmt(e['reported'])}, "
                         f"re-simulated {_fmt(e['validated'])}")
        else:
            label = e["metric"] + ("(" + ",".join(f"{k}={v}" for k, v in e["options"].items())
                                   + ")" if e["options"] else "")
            lines.append(f"warning: validation: {label} reported {_fmt(e['reported'])}, "
                         f"re-simulated {_fmt(e['validated'])}, gap {e['gap']:.3g} > "
                         f"tolerance {e['tolerance']:g}")
    if block and block.get("error"):
        lines.append(f"warning: validation: the validator failed: {block['error']}")
    return lines
