"""Koren 1979's design charts, computed by tuning with feedtune itself.

* Fig 6 (:func:`loci`): Kτ against T/τ for the minimum-IAE gain, the minimum-radial-error
  gain and the gain giving ζ = 0.707. Every point is a spec for the ``software_servo``
  plant tuned by :func:`feedtune.problem.tune` (T/τ = 0 is the reference-pulse loop).
  Overlays: eq 40, Kτ = 1/(T/τ + 2), and the ζ = 0.707 root of eqs 17–19.
* Fig 8 (:func:`min_radius`): minimum allowable radius r/BLU against τ f_m for the four
  designs (reference-pulse or sampled-data, minimum IAE or minimum radial error), the
  sampled ones at T f_m = 100 (eq 26 at its limit). Each gain is tuned and the radius is
  feedtune's exact ``min_radius`` at that gain; overlays: eq 34, eq 39 (corrected to
  4^(1/3), docs/errata.md) and, for minimum IAE sampled-data, eq 32.
* Fig 9 (:func:`selection`): the regions of (f_m, τ) where each technique applies, from
  eqs 2 and 27 (as Koren's own figure is).

Plots use matplotlib's Agg canvas (no display, no pyplot state).

References
----------
Y. Koren, "Design of Computer Control for Manufacturing Systems", ASME J. Eng. Ind.
101(3), 1979, pp. 326–332: eqs 2, 9, 17–19, 20, 26, 27, 29, 32–34, 36, 39, 40; Figs 6, 8, 9.
"""

from __future__ import annotations

import csv
import io
import json
import math
import time
from pathlib import Path
from typing import Callable, Iterable

import numpy as np

from feedtune.charts import selection as sel
from feedtune.schema.status import SKIPPED

KINDS = ("min_iae", "min_radial_error", "damping_0707")
LABELS = {
    "min_iae": "min IAE",
    "min_radial_error": "min radial error",
    "damping_0707": "ζ = 0.707",
}
#: ωT (or ωτ at T = 0) of the circle on which the radial error is minimised: Koren's
#: eqs 35/40 are the ωT → 0 limit; at 0.002 the exact optimum is within O((ωT)²) of it
OMEGA_T = 0.002
#: radius of that circle [m]; the optimum gain depends on ωT only
CIRCLE_RADIUS = 0.01
#: gain box [1/τ]: wide enough for every locus of Fig 6 (Kτ 0.2 … 0.6)
GAIN_BOX = (0.02, 5.0)
ZETA = 1 / math.sqrt(2)

Progress = Callable[[str], None]


# -- closed forms ----------------------------------------------------------------------

def eq40_k_tau(ratio: float) -> float:
    """Minimum radial error in the limit ωT → 0 (eqs 35, 40): Kτ = 1/(T/τ + 2)."""
    return 1 / (ratio + 2)


def koren_damping(k_tau: float, ratio: float) -> float:
    """ζ of the sampled loop by Koren's eqs 17–19 (τ = 1), continued: 1 for real poles
    (eq 18's arccos argument ≥ 1), and eq 9, 1/(2√(Kτ)), at T = 0."""
    if ratio == 0:
        return 1 / (2 * math.sqrt(k_tau))
    k, t = k_tau, ratio
    x = math.exp(-t)
    a2 = x + k * ((1 - x) - t * x)
    if a2 <= 0:
        return 1.0
    a = math.sqrt(a2)
    argument = (1 + x - k * t + k * (1 - x)) / (2 * a)
    if argument >= 1:
        return 1.0
    omega_t = math.acos(max(argument, -1.0))
    alpha_t = -math.log(a)
    return alpha_t / math.hypot(alpha_t, omega_t)


def zeta_k_tau(ratio: float, zeta: float = ZETA) -> float:
    """Kτ giving damping ratio ``zeta`` at T/τ = ``ratio``: eq 9 at T = 0, else the root of
    eqs 17–19 (brentq, independent of the plant's code)."""
    from scipy.optimize import brentq

    if ratio == 0:
        return 1 / (4 * zeta**2)
    low, high = 1e-4, 0.05
    while koren_damping(high, ratio) > zeta:
        high *= 1.5
        if high > 1e3:
            raise ValueError(f"no gain gives ζ = {zeta} at T/τ = {ratio}")
    return brentq(lambda k: koren_damping(k, ratio) - zeta, low, high, xtol=1e-14, rtol=1e-13)


def eq34_radius(tau_fm: float) -> float:
    """Eq 34: r/BLU = 0.4 (τ f_m)², reference-pulse at the minimum-IAE Kτ = 0.567."""
    return 0.4 * tau_fm**2


def eq39_radius(tau_fm: float, coefficient: float = sel.EQ39_COEFFICIENT) -> float:
    """Eq 39: r/BLU = c (τ f_m)^(4/3), c = 4^(1/3) (docs/errata.md; printed: 4)."""
    return coefficient * tau_fm ** (4 / 3)


# -- one tuned point --------------------------------------------------------------------

def point_spec(kind: str, time_constant: float, ratio: float, *, iae_time: str = "natural",
               omega_t: float = OMEGA_T, blu: float | None = None,
               max_velocity: float | None = None) -> dict:
    """The spec whose optimum is one point of a Fig 6 locus at T/τ = ``ratio``.

    ``ratio`` 0 is the reference-pulse loop (T = 0), otherwise sampled-data with T fixed.
    ``min_iae``: minimise the IAE of a unit step (``iae_time`` natural: over ω_n t, Koren's
    convention). ``min_radial_error``: minimise the exact steady radial error on a circle
    travelled at ωT = ``omega_t`` (ωτ at T = 0). ``damping_0707``: ζ = 0.707 as an equality
    constraint (the objective, maximum ω_n, only makes the problem well posed).
    """
    if kind not in KINDS:
        raise ValueError(f"unknown locus {kind!r}; one of {', '.join(KINDS)}")
    tau = time_constant
    plant = {"type": "software_servo",
             "technique": "reference_pulse" if ratio == 0 else "sampled_data",
             "time_constant": tau}
    if blu is not None:
        plant["blu"] = blu
    if max_velocity is not None:
        plant["max_velocity"] = max_velocity
    tunables = {"position_gain": {"min": GAIN_BOX[0] / tau, "max": GAIN_BOX[1] / tau}}
    if ratio > 0:
        tunables["sampling_period"] = {"value": ratio * tau}
    constraints = []
    if kind == "min_iae":
        objective = [{"metric": "iae", "time": iae_time}]
    elif kind == "min_radial_error":
        omega = omega_t / (ratio * tau if ratio > 0 else tau)
        objective = [{"metric": "radial_error", "radius": CIRCLE_RADIUS,
                      "feed": omega * CIRCLE_RADIUS}]
    else:
        objective = [{"metric": "natural_frequency", "goal": "maximize"}]
        constraints = [{"metric": "damping_ratio", "min": ZETA, "max": ZETA}]
    spec = {"name": f"koren-fig6-{kind}-{ratio:g}", "plant": plant, "tunables": tunables,
            "objective": objective, "solver": {"multistart": 4}}
    if constraints:
        spec["constraints"] = constraints
    return spec


def tune_point(kind: str, time_constant: float, ratio: float, **options) -> dict:
    """Tune :func:`point_spec` and return the point: Kτ, K [1/s], status, time [s] and the
    metrics the charts use (``min_radius`` [m], ``min_radius_koren`` [m], ``damping_ratio``).
    A gain on its bound or a failed solve gives ``k_tau`` None (not an optimum)."""
    from feedtune.problem import tune
    from feedtune.schema.spec import parse_spec

    spec = point_spec(kind, time_constant, ratio, **options)
    started = time.perf_counter()
    result = tune(parse_spec(spec))
    seconds = time.perf_counter() - started
    gain = result.tuned["position_gain"]
    ok = result.success and gain.at_bound is None
    metrics = {name: result.metrics[name].value for name in
               ("min_radius", "min_radius_koren", "damping_ratio") if name in result.metrics}
    return {"kind": kind, "ratio": ratio, "k_tau": gain.value * time_constant if ok else None,
            "gain": gain.value if ok else None, "status": result.status,
            "at_bound": gain.at_bound, "seconds": round(seconds, 4), **metrics}


def _grid(low: float, high: float, points: int, log: bool = False) -> list[float]:
    values = np.geomspace(low, high, points) if log else np.linspace(low, high, points)
    return [float(v) for v in values]


# -- Fig 6 ------------------------------------------------------------------------------

def loci(time_constant: float = 0.02, ratio_min: float = 0.0, ratio_max: float = 3.0,
         points: int = 13, iae_time: str = "natural", omega_t: float = OMEGA_T,
         kinds: Iterable[str] = KINDS, progress: Progress | None = None) -> dict:
    """Fig 6: each locus tuned at ``points`` values of T/τ in [ratio_min, ratio_max]."""
    ratios = _grid(ratio_min, ratio_max, points)
    series = {}
    started = time.perf_counter()
    for kind in kinds:
        rows = []
        for i, ratio in enumerate(ratios):
            if kind == "min_iae" and iae_time == "absolute" and ratio == 0:
                rows.append({"kind": kind, "ratio": ratio, "k_tau": None, "gain": None,
                             "status": f"{SKIPPED}: plain-time IAE has no interior optimum at "
                                       "T = 0 (docs/errata.md)"})
                if progress:
                    progress(f"{LABELS[kind]}: T/τ = 0 ({i + 1}/{len(ratios)}): skipped, no "
                             "interior optimum in plain time")
                continue
            row = tune_point(kind, time_constant, ratio, iae_time=iae_time, omega_t=omega_t)
            if kind == "min_radial_error":
                row["eq40_k_tau"] = eq40_k_tau(ratio)
            if kind == "damping_0707":
                row["eqs17_19_k_tau"] = zeta_k_tau(ratio)
            rows.append(row)
            if progress:
                value = "no interior optimum" if row["k_tau"] is None else f"Kτ = {row['k_tau']:.4f}"
                progress(f"{LABELS[kind]}: T/τ = {ratio:.4g} ({i + 1}/{len(ratios)}): {value}, "
                         f"{row['seconds']:.2f} s")
        series[kind] = {"label": LABELS[kind], "points": rows}
    dense = _grid(ratio_min, ratio_max, 121)
    return {
        "figure": "Koren 1979 Fig 6",
        "x": "T/tau [1]", "y": "K*tau [1]",
        "parameters": {"time_constant": time_constant, "iae_time": iae_time, "omega_t": omega_t,
                       "ratio_min": ratio_min, "ratio_max": ratio_max, "points": points},
        "series": series,
        "closed_forms": {
            "eq40": {"label": "eq 40: Kτ = 1/(T/τ + 2)",
                     "points": [{"ratio": r, "k_tau": eq40_k_tau(r)} for r in dense]},
            "eqs17_19": {"label": "eqs 17–19: ζ = 0.707",
                         "points": [{"ratio": r, "k_tau": zeta_k_tau(r)} for r in dense]},
        },
        "seconds": round(time.perf_counter() - started, 3),
    }


# -- Fig 8 ------------------------------------------------------------------------------

DESIGNS = {
    "reference_pulse_min_iae": ("min_iae", "reference-pulse, min IAE"),
    "sampled_data_min_iae": ("min_iae", "sampled-data, min IAE"),
    "reference_pulse_min_radial_error": ("min_radial_error", "reference-pulse, min e_r"),
    "sampled_data_min_radial_error": ("min_radial_error", "sampled-data, min e_r"),
}


def min_radius(tau_fm_min: float = 40.0, tau_fm_max: float = 1000.0, points: int = 12,
               encoder_ratio: float = sel.ENCODER_RATIO, time_constant: float = 0.02,
               blu: float = 1e-5, iae_time: str = "natural", omega_t: float = OMEGA_T,
               designs: Iterable[str] = tuple(DESIGNS), max_ratio: float = math.pi,
               progress: Progress | None = None) -> dict:
    """Fig 8: r/BLU against τ f_m, log-spaced, for each design criterion.

    The gain of each point is tuned (:func:`tune_point`) and its minimum radius is the exact
    ``min_radius`` at that gain (r·| |H(jV_m/r)| − 1 | = BLU/2). Sampled-data uses
    T = ``encoder_ratio``/f_m (eq 26 at its limit, Koren's T f_m = 100); points with
    T/τ ≥ ``max_ratio`` (eq 22: T/τ < π) are left out. r/BLU depends on τ f_m only, so
    ``time_constant`` [s] and ``blu`` [m] only set the specs' numbers.
    """
    grid = _grid(tau_fm_min, tau_fm_max, points, log=True)
    series = {}
    started = time.perf_counter()
    for name in designs:
        kind, label = DESIGNS[name]
        rows = []
        for i, tau_fm in enumerate(grid):
            f_m = tau_fm / time_constant
            sampled = name.startswith("sampled")
            ratio = encoder_ratio / tau_fm if sampled else 0.0
            if sampled and ratio >= max_ratio:
                rows.append({"tau_fm": tau_fm, "ratio": ratio, "r_blu": None,
                             "status": f"{SKIPPED}: T/τ = {ratio:.3g} ≥ {max_ratio:.4g} (eq 22)"})
                continue
            row = tune_point(kind, time_constant, ratio, iae_time=iae_time, omega_t=omega_t,
                             blu=blu, max_velocity=f_m * blu)
            radius = row.get("min_radius") if row["k_tau"] is not None else None
            formula = row.get("min_radius_koren") if row["k_tau"] is not None else None
            row.update({"tau_fm": tau_fm, "f_m": f_m,
                        "r_blu": None if radius is None else radius / blu,
                        "r_blu_formula": None if formula is None else formula / blu})
            if name == "reference_pulse_min_iae":
                row["eq34_r_blu"] = eq34_radius(tau_fm)
            if name == "reference_pulse_min_radial_error":
                row["eq39_r_blu"] = eq39_radius(tau_fm)
            rows.append(row)
            if progress:
                value = "no result" if row["r_blu"] is None else f"r/BLU = {row['r_blu']:.4g}"
                progress(f"{label}: τ f_m = {tau_fm:.4g} ({i + 1}/{len(grid)}): {value}, "
                         f"{row['seconds']:.2f} s")
        series[name] = {"label": label, "points": rows}
    dense = _grid(tau_fm_min, tau_fm_max, 100, log=True)
    return {
        "figure": "Koren 1979 Fig 8",
        "x": "tau*f_m [BLU]", "y": "r_min/BLU [1]",
        "parameters": {"tau_fm_min": tau_fm_min, "tau_fm_max": tau_fm_max, "points": points,
                       "encoder_ratio": encoder_ratio, "time_constant": time_constant,
                       "blu": blu, "iae_time": iae_time, "omega_t": omega_t},
        "series": series,
        "closed_forms": {
            "eq34": {"label": "eq 34: 0.4 (τf_m)²",
                     "points": [{"tau_fm": x, "r_blu": eq34_radius(x)} for x in dense]},
            "eq39": {"label": "eq 39 with 4^(1/3)",
                     "points": [{"tau_fm": x, "r_blu": eq39_radius(x)} for x in dense]},
            "eq39_printed": {"label": "eq 39 as printed (4)",
                             "points": [{"tau_fm": x, "r_blu": eq39_radius(x, 4.0)} for x in dense]},
        },
        "seconds": round(time.perf_counter() - started, 3),
    }


# -- Fig 9 ------------------------------------------------------------------------------

def selection(fm_min: float = 1e2, fm_max: float = 1e6, tau_min: float = 1e-3,
              tau_max: float = 1.0, execution_time: float = sel.EXECUTION_TIME,
              encoder_ratio: float = sel.ENCODER_RATIO,
              sampling_ratio: float = sel.SAMPLING_RATIO,
              design: dict | None = None) -> dict:
    """Fig 9: the boundaries f_m = 1/t_e (eq 2) and τ = (f_m/f_s)/((T/τ) f_m) (eq 27), and
    the region of each corner; ``design`` ({"time_constant", "pulse_rate"}) is marked."""
    boundary = encoder_ratio / sampling_ratio
    fm = _grid(fm_min, fm_max, 60, log=True)
    regions = {}
    for f in (fm_min, fm_max):
        for t in (tau_min, tau_max):
            regions[f"f_m={f:g},tau={t:g}"] = sel.region(t, f, execution_time, encoder_ratio,
                                                         sampling_ratio)
    data = {
        "figure": "Koren 1979 Fig 9",
        "x": "f_m [pulses/s]", "y": "tau [s]",
        "parameters": {"fm_min": fm_min, "fm_max": fm_max, "tau_min": tau_min,
                       "tau_max": tau_max, "execution_time": execution_time,
                       "encoder_ratio": encoder_ratio, "sampling_ratio": sampling_ratio},
        "series": {
            "eq2": {"label": "eq 2: f_m = 1/t_e",
                    "points": [{"f_m": 1 / execution_time, "tau": tau_min},
                               {"f_m": 1 / execution_time, "tau": tau_max}]},
            "eq27": {"label": f"eq 27: τ f_m = {boundary:.4g}",
                     "points": [{"f_m": f, "tau": boundary / f} for f in fm]},
        },
        "regions": regions,
    }
    if design is not None:
        data["design"] = {**design, "region": sel.region(design["time_constant"],
                                                         design["pulse_rate"], execution_time,
                                                         encoder_ratio, sampling_ratio)}
    return data


# -- output -----------------------------------------------------------------------------

def write_data(data: dict, path: Path) -> bytes:
    """The chart's points as JSON (everything) or CSV (one row per tuned or formula point,
    long format: series, then every field); the format follows the suffix."""
    if path.suffix.lower() == ".csv":
        rows = []
        for group in ("series", "closed_forms"):
            for name, entry in data.get(group, {}).items():
                for point in entry["points"]:
                    rows.append({"series": name, **point})
        fields = ["series"]
        for row in rows:
            fields.extend(k for k in row if k not in fields)
        out = io.StringIO()
        writer = csv.DictWriter(out, fieldnames=fields, lineterminator="\n")
        writer.writeheader()
        for row in rows:
            writer.writerow({k: "" if v is None else v for k, v in row.items()})
        return out.getvalue().encode("utf-8")
    return (json.dumps(data, indent=2, ensure_ascii=False) + "\n").encode("utf-8")


def _figure():
    from matplotlib.figure import Figure  # Agg canvas by default: no display needed

    figure = Figure(figsize=(7.5, 5.5), dpi=110)
    return figure, figure.add_subplot()


def _finish(figure, axes, target, fmt: str | None) -> None:
    """Save to ``target`` (a path or a binary file); ``fmt`` png/svg/pdf, default: the
    path's suffix."""
    axes.grid(True, which="both", alpha=0.3)
    axes.legend(fontsize=8)
    figure.tight_layout()
    if fmt is None:
        fmt = Path(target).suffix.lstrip(".").lower() or "png"
    figure.savefig(target, format=fmt)


def plot_loci(data: dict, target, fmt: str | None = None) -> None:
    figure, axes = _figure()
    styles = {"min_iae": ("tab:blue", "o"), "min_radial_error": ("tab:red", "s"),
              "damping_0707": ("tab:green", "^")}
    for name, entry in data["closed_forms"].items():
        pts = entry["points"]
        color = "tab:red" if name == "eq40" else "tab:green"
        axes.plot([p["ratio"] for p in pts], [p["k_tau"] for p in pts], "--", color=color,
                  lw=1, label=entry["label"])
    for name, entry in data["series"].items():
        pts = [p for p in entry["points"] if p["k_tau"] is not None]
        color, marker = styles[name]
        label = entry["label"] + (f" ({data['parameters']['iae_time']} time)" if name == "min_iae" else "")
        axes.plot([p["ratio"] for p in pts], [p["k_tau"] for p in pts], "-", color=color,
                  marker=marker, ms=4, label=label + ", tuned")
    axes.set_xlabel("T/τ [1]  (sampling period over drive time constant; 0: reference-pulse)")
    axes.set_ylabel("Kτ [1]  (open-loop gain K [1/s] × τ [s])")
    axes.set_title(f"Koren 1979 Fig 6: optimal loci of sampled-data systems "
                   f"(τ = {data['parameters']['time_constant']:g} s)", fontsize=10)
    axes.set_xlim(left=data["parameters"]["ratio_min"])
    _finish(figure, axes, target, fmt)


def plot_min_radius(data: dict, target, fmt: str | None = None) -> None:
    figure, axes = _figure()
    styles = {"reference_pulse_min_iae": ("tab:blue", "o"),
              "sampled_data_min_iae": ("tab:purple", "D"),
              "reference_pulse_min_radial_error": ("tab:red", "s"),
              "sampled_data_min_radial_error": ("tab:orange", "^")}
    for name, entry in data["series"].items():
        pts = [p for p in entry["points"] if p.get("r_blu") is not None]
        color, marker = styles[name]
        axes.plot([p["tau_fm"] for p in pts], [p["r_blu"] for p in pts], "-", color=color,
                  marker=marker, ms=4, label=entry["label"] + ", tuned, exact radius")
        if name == "sampled_data_min_iae":
            formula = [p for p in pts if p.get("r_blu_formula")]
            axes.plot([p["tau_fm"] for p in formula], [p["r_blu_formula"] for p in formula],
                      "--", color=color, lw=1, label="eq 32 at the tuned gain")
    shown = {"eq34": "tab:blue", "eq39": "tab:red", "eq39_printed": "0.6"}
    for name, entry in data["closed_forms"].items():
        pts = entry["points"]
        axes.plot([p["tau_fm"] for p in pts], [p["r_blu"] for p in pts],
                  ":" if name == "eq39_printed" else "--", color=shown[name], lw=1,
                  label=entry["label"])
    axes.set_xscale("log")
    axes.set_yscale("log")
    axes.set_xlabel("τ f_m [BLU]  (time constant τ [s] × max pulse rate f_m [pulses/s])")
    axes.set_ylabel("r_min/BLU [1]  (minimum allowable radius at V_m)")
    axes.set_title(f"Koren 1979 Fig 8: minimum allowable radii "
                   f"(sampled-data at T f_m = {data['parameters']['encoder_ratio']:g})",
                   fontsize=10)
    _finish(figure, axes, target, fmt)


def plot_selection(data: dict, target, fmt: str | None = None) -> None:
    figure, axes = _figure()
    p = data["parameters"]
    f = np.geomspace(p["fm_min"], p["fm_max"], 200)
    boundary = p["encoder_ratio"] / p["sampling_ratio"]
    limit = 1 / p["execution_time"]
    tau_b = np.clip(boundary / f, p["tau_min"], p["tau_max"])
    axes.fill_between(f, tau_b, p["tau_max"], where=f <= limit, color="tab:green", alpha=0.25,
                      label="either (reference-pulse preferred)")
    axes.fill_between(f, p["tau_min"], tau_b, where=f <= limit, color="tab:blue", alpha=0.25,
                      label="reference-pulse only")
    axes.fill_between(f, tau_b, p["tau_max"], where=f >= limit, color="tab:orange", alpha=0.3,
                      label="sampled-data only")
    axes.fill_between(f, p["tau_min"], tau_b, where=f >= limit, color="0.7", alpha=0.4,
                      label="neither")
    eq27 = data["series"]["eq27"]["points"]
    axes.plot([q["f_m"] for q in eq27], [q["tau"] for q in eq27], "k--", lw=1,
              label=data["series"]["eq27"]["label"])
    axes.axvline(limit, color="k", lw=1.2, label=data["series"]["eq2"]["label"])
    design = data.get("design")
    if design:
        axes.plot([design["pulse_rate"]], [design["time_constant"]], "k*", ms=12,
                  label=f"design: {design['region'].replace('_', '-')}")
    axes.set_xscale("log")
    axes.set_yscale("log")
    axes.set_xlim(p["fm_min"], p["fm_max"])
    axes.set_ylim(p["tau_min"], p["tau_max"])
    axes.set_xlabel("f_m [pulses/s]  (= V_m/BLU, eq 1)")
    axes.set_ylabel("τ [s]  (drive time constant)")
    axes.set_title("Koren 1979 Fig 9: selection of the CNC technique (eqs 2 and 27)", fontsize=10)
    _finish(figure, axes, target, fmt)


PLOTS = {"loci": plot_loci, "min-radius": plot_min_radius, "selection": plot_selection}
