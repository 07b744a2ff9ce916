"""Independent check of a result tuned on measured frequency responses (plant
``frequency_response_data``, the convex technique): no model to re-simulate, so the tuned
controller is re-evaluated on every measured frequency of every set, from the result's own
spec and tuned gains, with complex arithmetic of its own (not the design's matrices, its
SOCPs or its metric functions: :mod:`feedtune.measured` is not imported).

For each set it recomputes L = G K, |T| and |S| (and |W S| given a weight), the peaks at
the measured points and between them, the bandwidth, crossover and phase margin, and counts
the Nyquist turn of 1 + L again; each reported metric is compared with its re-measured
value, each bound is said to be held or violated with the measured worst value and its
frequency, and the stability verdict of each set is compared with the re-count.

Tolerances (each from a scale of the data, never relative to a value near 0):

* a peak between measured points is an interpolation; here a cubic spline in ln ω through
  the worst point and its three neighbours on each side (the design: a parabola through
  three). What the data can say about the peak is the measured maximum; the interpolation
  adds a correction of third order in the spacing. Two interpolants may differ by at most
  about that correction, so the tolerance is the larger of the two corrections (the spline's
  and the reported one's over the measured maximum), and at least 1e-9 (rounding of
  magnitudes of order 1, computed two ways);
* a crossing frequency (bandwidth, crossover) is interpolated log-log between the two
  measured points around it on both sides: 1e-6 of that interval (ω_i − ω_{i−1}), the
  measurement's resolution there, far above rounding;
* the phase margin: 1e-6 of the phase step of L between those two points, in degrees;
* a bound is held when the value is at most bound·(1 + 1e-6): the design's own slack for
  its solver's feasibility tolerance (1e-8 on constraints of order 1).

References
----------
G. F. Franklin, J. D. Powell, A. Emami-Naeini, "Feedback Control of Dynamic Systems",
§6.3 (the Nyquist criterion, Z = N + P).
S. Skogestad, I. Postlethwaite, "Multivariable Feedback Control", 2nd ed., §2.8.2 (the
performance weight W).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline

#: a frequency in these units, in rad/s
RAD_PER_S = {"rad/s": 1.0, "Hz": 2.0 * math.pi}
#: |T| = 1/√2 at the bandwidth (feedtune's −3 dB point)
HALF_POWER = 1.0 / math.sqrt(2.0)
#: a dip counts as the crossing only this far below its level [1, relative] (the metric's
#: definition, as the design states it: a solver's tangent is not a crossing)
DIP = 1e-6
#: bounds are held to bound·(1 + this) [1]
BOUND_SLACK = 1e-6
#: rounding of an O(1) magnitude computed two ways [1]
ROUNDING = 1e-9
#: crossing frequencies agree to this fraction of their measured interval [1]
RESOLUTION = 1e-6
#: the Nyquist count's conditions, as the result's certificate states them: 1 + L resolved
#: (< 60° a step), |L| ≤ 0.5 at the top of the band, |L| ≥ 2 where the low-end extension
#: starts (six decades below the band), the plant's phase within 45° of its asymptote
MAX_STEP = math.pi / 3
HIGH_GAIN, LOW_GAIN, DECADES, ASYMPTOTE = 0.5, 2.0, 6, math.pi / 4
#: points a decade of the low-end extension (the design uses 24; a different grid on purpose)
EXTENSION_PER_DECADE = 97
#: the peaks: compared as peaks; every other metric is a crossing or a margin
PEAKS = ("m_peak", "sensitivity_peak", "weighted_sensitivity")


@dataclass(frozen=True)
class MeasuredLoop:
    """One data set's loop at its measured frequencies.

    Attributes
    ----------
    name : str
    omega : ndarray
        ω [rad/s], increasing.
    plant : ndarray of complex
        G(jω) as measured [position per command].
    controller : ndarray of complex
        K(jω) of the tuned gains [command per position].
    weight : ndarray or None
        |W(jω)| [1] of the spec's sensitivity weight.
    """

    name: str
    omega: np.ndarray
    plant: np.ndarray
    controller: np.ndarray
    weight: np.ndarray | None

    @property
    def loop(self) -> np.ndarray:
        """L = G K [1]."""
        return self.plant * self.controller

    def magnitudes(self) -> dict[str, np.ndarray]:
        """|T|, |S| (and |W S|) [1] at the measured points, by the metric they bound."""
        x = 1.0 + self.loop
        out = {"m_peak": np.abs(self.loop) / np.abs(x), "sensitivity_peak": 1.0 / np.abs(x)}
        if self.weight is not None:
            out["weighted_sensitivity"] = self.weight / np.abs(x)
        return out


def controller_response(plant: dict, tuned: dict, omega: np.ndarray) -> np.ndarray:
    """K(jω) = k_p + k_i/(jω) + k_d jω/(τ_f jω + 1) of the spec's ``controller`` law at the
    tuned gains (``controller.kp`` …, absent terms 0) [command per position]."""
    s = 1j * omega
    law = plant.get("controller", "pid")
    k = s * 0 + tuned.get("controller.kp", 0.0)
    if "i" in law:
        k = k + tuned.get("controller.ki", 0.0) / s
    if "d" in law:
        k = k + tuned.get("controller.kd", 0.0) * s / (plant["filter_time_constant"] * s + 1.0)
    return k


def weight_magnitude(weight: dict | None, omega: np.ndarray) -> np.ndarray | None:
    """|W(jω)| = |(jω/M + ω_B)/(jω + ω_B A)| [1] of a spec's ``sensitivity_weight``."""
    if not weight:
        return None
    s = 1j * omega
    return np.abs((s / weight["peak"] + weight["bandwidth"]) /
                  (s + weight["bandwidth"] * weight["low_gain"]))


def measured_loops(spec: dict, tuned: dict) -> list[MeasuredLoop]:
    """Every set of a data-driven result's ``spec`` with the ``tuned`` gains (floats)."""
    plant = spec["plant"]
    loops = []
    for data in plant["sets"]:
        omega = np.asarray(data["frequency"], dtype=float) * RAD_PER_S[data["frequency_unit"]]
        g = np.asarray(data["real"], dtype=float) + 1j * np.asarray(data["imag"], dtype=float)
        loops.append(MeasuredLoop(data["name"], omega, g, controller_response(plant, tuned, omega),
                                  weight_magnitude(spec.get("sensitivity_weight"), omega)))
    return loops


def spline_peak(omega: np.ndarray, value: np.ndarray) -> tuple[float, float]:
    """(peak, ω at it [rad/s]) of ``value``: the measured maximum, refined by a cubic spline
    in ln ω through it and three neighbours a side, sampled 64 times between neighbours."""
    i = int(np.argmax(value))
    lo, hi = max(i - 3, 0), min(i + 4, len(value))
    if hi - lo < 4 or i in (0, len(value) - 1):
        return float(value[i]), float(omega[i])
    x = np.log(omega[lo:hi])
    fine = np.linspace(x[i - lo - 1], x[i - lo + 1], 129)
    curve = CubicSpline(x, value[lo:hi])(fine)
    j = int(np.argmax(curve))
    if curve[j] <= value[i]:
        return float(value[i]), float(omega[i])
    return float(curve[j]), float(math.exp(fine[j]))


def first_crossing(omega: np.ndarray, value: np.ndarray, level: float
                   ) -> tuple[float | None, float]:
    """(ω [rad/s] where ``value`` first falls below ``level``, log-log interpolated, or None;
    the measured interval around it [rad/s], 0 at the first point or none)."""
    for i, v in enumerate(value):
        if v < level * (1.0 - DIP):
            if i == 0:
                return float(omega[0]), 0.0
            t = (math.log(level) - math.log(value[i - 1])) / (math.log(v) - math.log(value[i - 1]))
            w = math.exp(math.log(omega[i - 1]) + t * (math.log(omega[i]) - math.log(omega[i - 1])))
            return w, float(omega[i] - omega[i - 1])
    return None, 0.0


def phase_margin(loop: MeasuredLoop, crossover: float | None) -> tuple[float | None, float]:
    """(180° + the phase of L at the crossover [deg], within (−180°, 180°]; the phase step of
    L between the points around it [deg])."""
    if crossover is None:
        return None, 0.0
    angle = np.angle(loop.loop)
    steps = np.angle(loop.loop[1:] / loop.loop[:-1])   # principal increments
    phase = angle[0] + np.concatenate([[0.0], np.cumsum(steps)])
    i = int(np.searchsorted(loop.omega, crossover))
    i = min(max(i, 1), len(loop.omega) - 1)
    t = (math.log(crossover) - math.log(loop.omega[i - 1])) / (
        math.log(loop.omega[i]) - math.log(loop.omega[i - 1]))
    at = phase[i - 1] + t * (phase[i] - phase[i - 1])
    margin = math.degrees(at) + 180.0
    margin -= 360.0 * math.floor((margin + 180.0) / 360.0)
    return margin, abs(math.degrees(phase[i] - phase[i - 1]))


def nyquist_count(loop: MeasuredLoop, plant_integrators: int, controller_integrators: int,
                  unstable_poles: int, plant: dict, tuned: dict) -> dict:
    """The turn of 1 + L from 0⁺ to ∞, counted again, and the closed-loop poles in the
    right half-plane it implies: Z = P + (expected − turn)/π with expected (n + 2P)·π/2.

    The measured band is summed as principal increments of arg(1 + L) between neighbours;
    below it, the plant's integrator asymptote c/(jω)^{n_G} (c from the lowest point) with
    the known controller, on a grid of its own; from ω → 0⁺ the turn starts at L's
    asymptote −nπ/2 (+ π when c·k₀ < 0; k₀ the controller's lowest-order gain; c is real
    for a real plant, its measured phase within 45° of it); beyond the band 1 + L returns
    to 1. The turn is then a multiple of π/2 up to the plant's measured phase offset at the
    lowest point, which the rounding to a pole count absorbs.

    Returns
    -------
    dict
        ``turn_rad``, ``expected_rad``, ``rhp_poles`` (None when a condition fails),
        ``stable``, ``reason``.
    """
    n = plant_integrators + controller_integrators
    expected = (n + 2 * unstable_poles) * math.pi / 2
    out = {"name": loop.name, "turn_rad": None, "expected_rad": expected, "rhp_poles": None,
           "stable": False}
    w0 = loop.omega[0]
    c = loop.plant[0] * (1j * w0) ** plant_integrators
    if abs(math.sin(np.angle(c))) > math.sin(ASYMPTOTE):
        return {**out, "reason": "the plant's lowest measured point is off its integrators' "
                                 "asymptote by more than 45°"}
    low = w0 * 10.0 ** np.linspace(-DECADES, 0, DECADES * EXTENSION_PER_DECADE, endpoint=False)
    omega = np.concatenate([low, loop.omega])
    g = np.concatenate([c / (1j * low) ** plant_integrators, loop.plant])
    l = g * np.concatenate([controller_response(plant, tuned, low), loop.controller])
    if not np.all(np.isfinite(l)):
        return {**out, "reason": "L is not finite"}
    if abs(l[-1]) > HIGH_GAIN:
        return {**out, "reason": f"|L| = {abs(l[-1]):.3g} > {HIGH_GAIN} at the top of the band"}
    x = 1.0 + l
    if np.any(x == 0):
        return {**out, "reason": "1 + L = 0 at a measured point"}
    steps = np.angle(x[1:] / x[:-1])
    if np.max(np.abs(steps)) > MAX_STEP:
        return {**out, "reason": "the phase of 1 + L is not resolved by the points (> 60° a step)"}
    if n > 0 and abs(l[0]) < LOW_GAIN:
        return {**out, "reason": f"|L| = {abs(l[0]):.3g} < {LOW_GAIN} six decades below the band"}
    if n > 0:  # L ≈ c k₀/(jω)^n as ω → 0⁺, c real for a real plant: −nπ/2, + π if c k₀ < 0
        k0 = tuned.get("controller.ki" if controller_integrators else "controller.kp", 0.0)
        start = -n * math.pi / 2 + (0.0 if (c * k0).real > 0 else math.pi)
    else:
        start = 0.0 if x[0].real > 0 else math.pi          # L(0) real
    last = start + float(np.angle(x[0] * np.exp(-1j * start))) + float(np.sum(steps))
    turn = last - float(np.angle(np.exp(1j * last))) - start  # 1 + L → 1 beyond the band
    poles = int(round((expected - turn) / math.pi))
    return {**out, "turn_rad": float(turn), "rhp_poles": poles, "stable": poles == 0,
            "reason": f"1 + L turns by {turn / math.pi:.3g}π against {expected / math.pi:.3g}π: "
                      f"{poles} closed-loop pole(s) in the right half-plane"}


def _entry(metric: str, options: dict, reported, validated, unit: str, gap, tolerance, basis,
           ok: bool, **extra) -> dict:
    return {"metric": metric, "options": options, "reported": reported, "validated": validated,
            "unit": unit, "gap": gap, "tolerance": tolerance, "basis": basis, "ok": bool(ok),
            **extra}


def set_values(loop: MeasuredLoop) -> dict[str, tuple]:
    """Each metric of one set → (value, tolerance, basis, extra fields) as re-measured."""
    values = {}
    for name, magnitude in loop.magnitudes().items():
        measured = float(magnitude.max())
        peak, at = spline_peak(loop.omega, magnitude)
        values[name] = (peak, max(peak - measured, ROUNDING), "the interpolation's correction",
                        {"measured_worst": measured,
                         "measured_at": float(loop.omega[int(np.argmax(magnitude))]),
                         "interpolated_at": at})
    t = loop.magnitudes()["m_peak"]
    for name, value, level in (("bandwidth", t, HALF_POWER),
                               ("crossover_frequency", np.abs(loop.loop), 1.0)):
        w, interval = first_crossing(loop.omega, value, level)
        values[name] = (w, RESOLUTION * interval, f"{RESOLUTION:g} of the measured interval", {})
    margin, step = phase_margin(loop, values["crossover_frequency"][0])
    values["phase_margin"] = (margin, RESOLUTION * step,
                              f"{RESOLUTION:g} of L's phase step there", {})
    return values


def _compare(metric: str, options: dict, record: dict | None, value, tolerance, basis,
             extra: dict) -> dict | None:
    """A reported metric against its re-measured value (None when the result has none)."""
    if record is None:
        return None
    reported = record.get("value")
    if reported is None or value is None:
        return _entry(metric, options, reported, value, record.get("unit"), None, tolerance,
                      basis, reported is None and value is None, **extra)
    if metric in PEAKS:  # the reported interpolant's own correction counts too
        tolerance = max(tolerance, reported - extra["measured_worst"])
    gap = abs(reported - value)
    return _entry(metric, options, reported, value, record.get("unit"), gap, tolerance, basis,
                  gap <= tolerance, **extra)


def validate_measured(result: dict) -> list[dict]:
    """The ``validation`` entries of a data-driven ``result`` (JSON form): every reported
    metric per set and worst over the sets against its re-measured value, every bound per
    set as held or violated (``reported``: the bound, ``validated``: the worst value between
    the points; ``held``, ``claimed``: the result's ``satisfied``; ``measured_worst`` at the
    points and ``measured_at`` [rad/s]; ``ok`` unless violated where the result claims it),
    and each set's stability against the Nyquist count made again (``stable``, with
    ``rhp_poles`` and ``turn_rad``)."""
    spec = result["spec"]
    plant = spec["plant"]
    tuned = {name: t["value"] for name, t in result["tuned"].items()}
    metrics = result.get("metrics") or {}
    loops = measured_loops(spec, tuned)
    entries, per_set = [], []
    for loop in loops:
        values = set_values(loop)
        per_set.append(values)
        for name, (value, tolerance, basis, extra) in values.items():
            entry = _compare(name, {"set": loop.name}, metrics.get(f"{name}(set={loop.name})"),
                             value, tolerance, basis, extra)
            if entry is not None:
                entries.append(entry)
    for name in per_set[0]:  # the worst over the sets
        values = [v[name] for v in per_set]
        if any(v[0] is None for v in values):
            worst = (None, 0.0, values[0][2], {})
        else:
            worst = (max if name in PEAKS else min)(values, key=lambda v: v[0])
        entry = _compare(name, {}, metrics.get(name), *worst)
        if entry is not None:
            entries.append(entry)
    reported = {c["metric"]: c for c in result.get("constraints") or []}
    for constraint in spec.get("constraints") or []:
        name, bound = constraint["metric"], constraint["max"]
        said = reported.get(name, {}).get("satisfied")
        for loop, values in zip(loops, per_set):
            value, _, _, extra = values[name]
            held = value <= bound * (1 + BOUND_SLACK)
            entries.append(_entry(
                name, {"set": loop.name, "bound": "max"}, bound, value, "1", None, None,
                f"≤ {bound:g}·(1 + {BOUND_SLACK:g})", held or said is False,
                bound=bound, held=bool(held), claimed=said, worst=value, **extra))
    sets = {s.get("name"): s for s in (result.get("stability") or {}).get("sets") or []}
    controller_integrators = 1 if "i" in plant.get("controller", "pid") else 0
    for loop in loops:
        count = nyquist_count(loop, plant.get("integrators", 1), controller_integrators,
                              plant.get("unstable_poles", 0), plant, tuned)
        said = sets.get(loop.name, {}).get("stable")
        entries.append(_entry("stable", {"set": loop.name}, said, count["stable"], None, None,
                              None, "the Nyquist count", said == count["stable"],
                              rhp_poles=count["rhp_poles"], turn_rad=count["turn_rad"],
                              expected_rad=count["expected_rad"], reason=count["reason"]))
    return entries
