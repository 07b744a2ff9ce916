"""The report's figures, one function each, drawn from a validator model and the result.

Each function takes the model (:mod:`feedtune.validate.model`) and the result dict and
returns a matplotlib Figure, or raises :class:`~feedtune.validate.model.NotCovered` with
the reason it cannot be drawn. Curves come from the model (numpy/scipy, independent of
the tuner); the values marked on them are the result's reported metrics, so a reader sees
whether the tuner's numbers sit where the re-simulated curves say they should.
Matplotlib's Agg canvas, no pyplot state.
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from scipy.optimize import brentq

from feedtune.schema.model import read_number
from feedtune.validate.model import NotCovered

#: figure size [in] and resolution [dpi] of every PNG
SIZE, DPI = (7.5, 5.0), 100
#: a displayed response ends when it stays within this fraction of its largest excursion
DISPLAY_SETTLED = 2e-3
#: Bode plots span this factor beyond the lowest and highest characteristic frequency
BODE_DECADE = 10.0
#: a closed-loop |H| peak this factor (0.1 dB) above its low-frequency value is a resonance
RESONANCE = 10 ** (0.1 / 20)
#: the scan for the characteristic frequencies: [points per decade], and the factor it
#: extends beyond the slowest and fastest pole
SCAN_POINTS, SCAN_SPAN = 40, 1e3
#: Bode grid density [points per decade]
BODE_POINTS = 400
#: the margins' scan of a continuous loop extends this factor beyond the Bode range
MARGIN_SPAN = 1e2
#: micrometres per metre: the circle figure's deviations are in µm
UM = 1e6
#: the circle figure's ring spans at least this deviation range [m] (1 nm, far below a
#: BLU), so a path with no deviation at all is still drawn on a readable scale
CIRCLE_MIN_SPAN = 1e-9
#: the zoomed circle deviation shows this many interpolator sides, or degrees without one
ZOOM_SIDES, ZOOM_DEGREES = 4, 30


def metric(result: dict, name: str, **options) -> float | None:
    """The reported value of metric ``name`` whose options include ``options`` (±∞ where
    the result's JSON says "Infinity" / "-Infinity"), or None."""
    for m in (result.get("metrics") or {}).values():
        value = read_number(m.get("value"))
        if m.get("metric") == name and value is not None and all(
                (m.get("options") or {}).get(k) == v for k, v in options.items()):
            return value
    return None


def new_figure(width: float, height: float) -> Figure:
    """A Figure of ``width`` × ``height`` [in] at DPI on an Agg canvas of its own.

    With its canvas, the figure's ``tight_layout`` and the report's ``savefig`` draw with
    one renderer, whose caches of text extents and parsed mathtext (matplotlib keeps them
    per renderer) the second pass reuses. A Figure without one got a fresh renderer for
    each pass, so every tick label was measured, and every log-axis label parsed, twice
    (benchmarks/report_figures.py: the same PNG bytes; benchmarks/README.md "Branch
    h-tdup").
    """
    figure = Figure(figsize=(width, height), dpi=DPI)
    FigureCanvasAgg(figure)
    return figure


def _figure(rows: int = 1, cols: int = 1, height: float | None = None):
    figure = new_figure(SIZE[0], height or SIZE[1])
    axes = figure.subplots(rows, cols, squeeze=False)
    return figure, axes


def _display_end(t: np.ndarray, y: np.ndarray) -> int:
    """Index after which y stays within DISPLAY_SETTLED of its final value (plus 30 %)."""
    dev = np.abs(y - y[-1])
    big = np.nonzero(dev > DISPLAY_SETTLED * max(float(np.max(dev)), 1e-300))[0]
    if big.size == 0:
        return len(t)
    end_time = 1.3 * t[big[-1]]
    return int(np.searchsorted(t, end_time)) + 1


def _note(ax, lines: list[str], left: bool = False) -> None:
    """A box of ``lines`` in the lower right (``left``: lower left) corner of ``ax``."""
    if lines:
        ax.text(0.02 if left else 0.98, 0.04, "\n".join(lines), transform=ax.transAxes,
                ha="left" if left else "right", va="bottom", fontsize=8,
                bbox={"boxstyle": "round", "fc": "white", "alpha": 0.85})


def _g(value: float) -> str:
    return f"{value:.4g}"


def responses_figure(model, result: dict) -> Figure:
    """Step, ramp and load-torque responses with the result's time-domain metrics."""
    responses = model.responses()
    kinds = [k for k in ("step", "ramp", "load") if k in responses]
    if not kinds:
        raise NotCovered("the model has no time response")
    figure, axes = _figure(len(kinds), 1, height=2.6 * len(kinds) + 0.6)
    for ax, kind in zip(axes[:, 0], kinds):
        r = responses[kind]
        unit = r.unit
        if kind == "step":
            end = _display_end(r.time, r.position)
            ax.plot(r.time[:end], r.reference[:end], "--", color="0.5", label="reference")
            ax.plot(r.time[:end], r.position[:end], label="position")
            ax.set_ylabel(f"position [{unit}]")
            size = float(r.reference[-1])
            ax.set_title("unit step" if size == 1 else f"step of {_g(size)} {unit}", fontsize=10)
            lines = []
            for name, label, u in (("iae", "IAE", f"{unit}·s"), ("ise", "ISE", f"{unit}²·s"),
                                   ("itae", "ITAE", f"{unit}·s²")):
                value = metric(result, name, input="step", time="absolute")
                if value is not None:
                    lines.append(f"{label} {_g(value)} {u}")
            overshoot = metric(result, "overshoot")
            if overshoot is not None:
                lines.append(f"overshoot {100 * overshoot:.3g} %")
                ax.axhline(1 + overshoot, color="C3", lw=0.8, ls=":")
            settling = metric(result, "settling_time", input="step")
            if settling is not None:
                ax.axvline(settling, color="C2", lw=0.8, ls=":")
                lines.append(f"settling time {_g(settling)} s")
            for name, label, u in (("pulse_rise_time", "rise time 10–90 %", " s"),
                                   ("pulse_settling_time", "settling time", " s"),
                                   ("pulse_max_velocity", "max velocity", f" {unit}/s"),
                                   ("peak_commanded_acceleration", "peak commanded acceleration",
                                    f" {unit}/s²"),
                                   ("damping_ratio", "ζ", ""), ("natural_frequency", "ω_n", " rad/s")):
                value = metric(result, name)
                if value is not None:
                    lines.append(f"{label} {_g(value)}{u}")
            _note(ax, lines)
            ax.legend(loc="upper right", fontsize=8)
        elif kind == "ramp":
            end = _display_end(r.time, r.error)
            ax.plot(r.time[:end], r.error[:end], label="following error")
            ax.set_ylabel(f"error [{unit}]")
            ax.set_title("unit ramp (1 " + unit + "/s): following error", fontsize=10)
            lines = []
            cv = metric(result, "velocity_constant")
            if cv is not None:
                ax.axhline(1 / cv, color="C3", lw=0.8, ls=":", label="1/C_v")
                lines.append(f"C_v {_g(cv)} 1/s → steady error {_g(1 / cv)} {unit}")
            value = metric(result, "iae", input="ramp")
            if value is not None:
                lines.append(f"IAE {_g(value)} {unit}·s")
            _note(ax, lines)
            ax.legend(loc="upper right", fontsize=8)
        else:
            end = _display_end(r.time, r.position)
            ax.plot(r.time[:end], r.position[:end], label="position")
            ax.set_ylabel(f"position [{unit}]")
            ax.set_title("unit load-torque step, reference still", fontsize=10)
            lines = []
            peak = metric(result, "load_rejection", measure="peak")
            if peak is not None:
                ax.axhline(-peak, color="C3", lw=0.8, ls=":")
                ax.axhline(peak, color="C3", lw=0.8, ls=":")
                lines.append(f"peak error {_g(peak)} {unit}")
            iae = metric(result, "load_rejection", measure="iae")
            if iae is not None:
                lines.append(f"IAE {_g(iae)} {unit}·s")
            _note(ax, lines)
        ax.grid(True, alpha=0.3)
    axes[-1, 0].set_xlabel("time [s]")
    figure.tight_layout()
    return figure


def _s_poles(model) -> np.ndarray:
    """Closed-loop poles in the s-plane [1/s]; a sampled loop's by s = ln(z)/T (z = 0 has
    none)."""
    poles = np.asarray(model.poles(), dtype=complex)
    if model.sampled:
        poles = np.log(poles[poles != 0]) / model.period
    return poles


def _crossings(omega: np.ndarray, f: np.ndarray, level: float, curve) -> list[float]:
    """Every ω [rad/s] where ``f`` (sampled on ``omega``) crosses ``level``, refined by
    Brent's method on ``curve(ω) − level`` in log ω."""
    above = f > level
    found = []
    for i in np.nonzero(above[:-1] != above[1:])[0]:
        found.append(math.exp(brentq(lambda x: curve(math.exp(x)) - level,
                                     math.log(omega[i]), math.log(omega[i + 1]), xtol=1e-9)))
    return found


def characteristic_frequencies(model) -> dict[str, float]:
    """The frequencies [rad/s] that set a Bode diagram's range.

    ``slowest pole`` and ``dominant pole`` (largest real part) are |s| of closed-loop poles;
    ``crossover`` the highest ω where |L| = 1, ``bandwidth`` the first ω where |H| falls
    3 dB below its low-frequency value, ``peak`` the ω of the largest |H| (where it is
    not at an end of the scan and at least RESONANCE above the low-frequency gain).
    Found on a SCAN_POINTS-per-decade scan from the slowest pole / SCAN_SPAN to the
    fastest × SCAN_SPAN (to the Nyquist frequency π/T for a sampled loop), crossings
    refined by Brent's method.
    """
    poles = _s_poles(model)
    speeds = np.abs(poles)
    alive = speeds > 0
    if not np.any(alive):
        raise NotCovered("no nonzero pole to set the frequency range")
    freqs = {"slowest pole": float(np.min(speeds[alive])),
             "dominant pole": float(speeds[alive][np.argmax(poles[alive].real)])}
    low = freqs["slowest pole"] / SCAN_SPAN
    high = (math.pi / model.period * (1 - 1e-6) if model.sampled
            else float(np.max(speeds)) * SCAN_SPAN)
    omega = np.logspace(math.log10(low), math.log10(high),
                        int(SCAN_POINTS * math.log10(high / low)) + 2)
    open_loop, closed = (np.abs(h) for h in model.frequency_response(omega))

    def gain(w: float, which: int) -> float:  # |L| (0) or |H| (1) at ω = w [rad/s]
        return float(np.abs(model.frequency_response(np.array([w]))[which][0]))

    crossings = _crossings(omega, np.log(open_loop), 0.0, lambda w: math.log(gain(w, 0)))
    if crossings:
        freqs["crossover"] = crossings[-1]
    steady = gain(freqs["slowest pole"] * 1e-6, 1)  # |H(0)| to ~1e-12
    dips = _crossings(omega, np.log(closed / steady), -0.5 * math.log(2),
                      lambda w: math.log(gain(w, 1) / steady))
    if dips:
        freqs["bandwidth"] = dips[0]
    peak = int(np.argmax(closed))
    if 0 < peak < len(omega) - 1 and closed[peak] > RESONANCE * steady:
        freqs["peak"] = float(omega[peak])
    return freqs


def bode_range(model) -> tuple[float, float]:
    """(low, high) [rad/s]: a factor BODE_DECADE below the lowest and above the highest
    :func:`characteristic_frequencies`, not the fastest pole's (a hydraulic pole at
    4.5e5 rad/s says nothing about a 700 rad/s loop); a sampled loop ends at the Nyquist
    frequency π/T, at least two decades above ``low``."""
    freqs = characteristic_frequencies(model).values()
    low, high = min(freqs) / BODE_DECADE, max(freqs) * BODE_DECADE
    if model.sampled:
        high = math.pi / model.period * (1 - 1e-6)
        low = min(low, high / 1e2)
    return low, high


def margin_marks(model, result: dict, low: float,
                 high: float) -> dict[str, tuple[float, float]]:
    """Where the margin arrows go: ``phase`` (ω_c [rad/s], −180° + reported phase margin
    [deg]) at the gain crossover |L| = 1, ``gain`` (ω_180 [rad/s], −20·log10 of the reported
    gain margin [dB]) at a phase crossover, each where the result reports that margin.

    ω_c is the reported crossover frequency when there is one, else located on the model's
    |L|. The phase crossovers are where L crosses the negative real axis (Im L changes
    sign with Re L < 0: arg L ≡ −180° modulo 360°, so a type-3 loop whose phase starts at
    −270° has one where it rises through −180°), on a scan of [``low``, ``high``] [rad/s]
    widened by MARGIN_SPAN on both sides for a continuous loop (a crossover beyond the
    Bode range, e.g. a dead time's), up to π/T for a sampled one (where L(−1) real and
    negative is a crossover); of several, the one whose 1/|L| is nearest the reported gain
    margin (in dB). A loop whose L never crosses the negative real axis has no gain
    margin to mark (it is infinite). The arrows' lengths are the reported values: their
    tips sit on the model's curves when the tuner and the model agree; :func:`bode_figure`
    widens its range to every mark."""
    marks = {}
    if not model.sampled:
        low, high = low / MARGIN_SPAN, high * MARGIN_SPAN
    omega = np.geomspace(low, high, int(SCAN_POINTS * math.log10(high / low)) + 2)
    open_loop = model.frequency_response(omega)[0]

    def at(w: float) -> complex:
        return complex(model.frequency_response(np.array([w]))[0][0])

    pm = metric(result, "phase_margin")
    if pm is not None:
        crossover = metric(result, "crossover_frequency")
        if crossover is None:
            found = _crossings(omega, np.log(np.abs(open_loop)), 0.0,
                               lambda w: math.log(abs(at(w))))
            crossover = found[0] if found else None
        if crossover is not None:
            marks["phase"] = (float(crossover), -180.0 + pm)
    gm = metric(result, "gain_margin")
    if gm is not None and 0 < gm < math.inf:  # +∞: no phase crossover, nothing to mark
        crossings = [w for w in _crossings(omega, np.sign(open_loop.imag), 0.0,
                                           lambda w: at(w).imag)
                     if at(w).real < 0]
        if model.sampled and open_loop[-1].real < 0:
            crossings.append(high)
        if crossings:
            where = min(crossings, key=lambda w: abs(math.log(abs(at(w)) * gm)))
            marks["gain"] = (where, -20 * math.log10(gm))
    return marks


def bode_figure(model, result: dict) -> Figure:
    """|L|, |H| [dB] and their phases [deg]; M_peak, bandwidth, crossover and margins."""
    low, high = bode_range(model)
    marks = margin_marks(model, result, low, high)
    if not model.sampled:  # a margin beyond the range: widen it to show the mark
        for w, _ in marks.values():
            low, high = min(low, w / 2), max(high, w * 2)
    omega = np.logspace(math.log10(low), math.log10(high),
                        int(BODE_POINTS * math.log10(high / low)) + 1)
    open_loop, closed = model.frequency_response(omega)
    figure, axes = _figure(2, 1, height=6.0)
    mag, phase = axes[0, 0], axes[1, 0]
    for h, label in ((open_loop, "open loop L"), (closed, "closed loop H")):
        mag.semilogx(omega, 20 * np.log10(np.abs(h)), label=label)
        phase.semilogx(omega, np.degrees(np.unwrap(np.angle(h))), label=label)
    lines = []
    m_peak = metric(result, "m_peak")
    if m_peak is not None:
        mag.axhline(20 * math.log10(m_peak), color="C3", lw=0.8, ls=":")
        lines.append(f"M_peak {_g(m_peak)} ({20 * math.log10(m_peak):.2f} dB)")
    bandwidth = metric(result, "bandwidth")
    if bandwidth is not None:
        mag.axvline(bandwidth, color="C2", lw=0.8, ls=":")
        mag.axhline(-3.0103, color="0.6", lw=0.6, ls=":")
        lines.append(f"bandwidth {_g(bandwidth)} rad/s")
    crossover = metric(result, "crossover_frequency")
    if crossover is not None:
        for ax in (mag, phase):
            ax.axvline(crossover, color="C4", lw=0.8, ls=":")
        lines.append(f"crossover {_g(crossover)} rad/s")
    pm = metric(result, "phase_margin")
    if pm is not None:
        phase.axhline(-180 + pm, color="C4", lw=0.8, ls=":")
        lines.append(f"phase margin {_g(pm)}°")
    gm = metric(result, "gain_margin")
    if gm == math.inf:
        lines.append("gain margin ∞ (the phase never reaches −180°)")
    elif gm is not None:
        mag.axhline(-20 * math.log10(gm), color="C5", lw=0.8, ls=":")
        lines.append(f"gain margin {_g(gm)} ({20 * math.log10(gm):.2f} dB)")
    if "phase" in marks:  # the arrow from −180° up to the phase at the crossover
        w, top = marks["phase"]
        phase.annotate("", xy=(w, top), xytext=(w, -180.0),
                       arrowprops={"arrowstyle": "->", "color": "C4", "lw": 1.2})
        phase.annotate("PM", xy=(w, (top - 180.0) / 2), xytext=(4, 0),
                       textcoords="offset points", color="C4", fontsize=8, va="center")
    if "gain" in marks:  # the arrow from |L| at the phase crossover up to 0 dB
        w, bottom = marks["gain"]
        mag.annotate("", xy=(w, 0.0), xytext=(w, bottom),
                     arrowprops={"arrowstyle": "->", "color": "C5", "lw": 1.2})
        mag.annotate("GM", xy=(w, bottom / 2), xytext=(4, 0), textcoords="offset points",
                     color="C5", fontsize=8, va="center")
    phase.axhline(-180, color="0.6", lw=0.6)
    if model.sampled:
        for ax in (mag, phase):
            ax.axvline(math.pi / model.period, color="k", lw=0.8)
        lines.append(f"Nyquist π/T = {_g(math.pi / model.period)} rad/s")
    _note(mag, lines, left=True)  # |L| and |H| fall to the lower right
    mag.set_ylabel("magnitude [dB]")
    phase.set_ylabel("phase [deg]")
    phase.set_xlabel("frequency ω [rad/s]")
    mag.legend(loc="upper right", fontsize=8)
    for ax in (mag, phase):
        ax.grid(True, which="both", alpha=0.3)
    mag.set_title("Bode diagram" + (" (sampled loop, z = e^(jωT))" if model.sampled else ""),
                  fontsize=10)
    figure.tight_layout()
    return figure


def circle_options(result: dict) -> tuple[float, float]:
    """(radius [m], feed [m/s]) of the first circle metric in the result."""
    for m in (result.get("metrics") or {}).values():
        options = m.get("options") or {}
        if "radius" in options and "feed" in options:
            return float(options["radius"]), float(options["feed"])
    raise NotCovered("no circle metric (radius and feed) in the result")


def circle_limits(result: dict) -> list[tuple[float, str]]:
    """(radial deviation [m], label) of every constraint bound that places the path: a
    ``radius_decrease`` max Δr at −Δr, ``circle_mean_deviation`` min/max as they are, a
    ``radial_error`` max e at ±e."""
    limits = []
    for c in result.get("constraints") or []:
        low, high, name = c.get("min"), c.get("max"), c.get("metric")
        if name == "radius_decrease" and high is not None:
            limits.append((-high, f"constraint Δr ≤ {_g(high * UM)} µm"))
        elif name == "circle_mean_deviation":
            limits += [(v, f"constraint mean deviation {op} {_g(v * UM)} µm")
                       for v, op in ((low, "≥"), (high, "≤")) if v is not None]
        elif name == "radial_error" and high is not None:
            limits += [(v, f"constraint |radial error| ≤ {_g(high * UM)} µm")
                       for v in (-high, high)]
    return limits


def circle_figure(model, result: dict) -> Figure:
    """The steady circle test, ballbar style: the radial deviation [µm] from the commanded
    radius around the revolution (a ring, not to scale: its width is the deviation range),
    with the commanded radius, the band between the smallest and largest deviation
    (circularity), the constraint bounds and the zoomed wedge marked; below, the deviation
    [µm] over the first few interpolator sides (or degrees)."""
    if model.position_unit != "m":
        raise NotCovered(f"a rotary axis (position in {model.position_unit}): no two-axis "
                         "circle test")
    radius, feed = circle_options(result)
    trace = model.circle_test(radius, feed)
    angle = np.unwrap(np.asarray(trace.angle))
    dev = np.asarray(trace.deviation) * UM
    mean, low, high = float(np.mean(dev)), float(np.min(dev)), float(np.max(dev))
    limits = [(v * UM, label) for v, label in circle_limits(result)]
    shown = [0.0, low, high] + [v for v, _ in limits]
    span = max(max(shown) - min(shown), CIRCLE_MIN_SPAN * UM)
    r_min, r_max = min(shown) - 0.15 * span, max(shown) + 0.15 * span
    interval = getattr(model, "reference_interval", None)
    wedge = ZOOM_SIDES * interval * feed / radius if interval else math.radians(ZOOM_DEGREES)
    figure = new_figure(6.5, 9.5)
    grid = figure.add_gridspec(3, 1, height_ratios=[4.0, 1.6, 0.7])
    ax = figure.add_subplot(grid[0], projection="polar")
    ax.set_rorigin(r_min - (r_max - r_min))  # a ring: the centre is not r = 0
    ax.set_rlim(r_min, r_max)
    theta = np.linspace(0, 2 * math.pi, 721)
    ax.fill_between(theta, low, high, color="C0", alpha=0.15, lw=0,
                    label=f"circularity band (max − min) {_g(high - low)} µm")
    ax.plot(theta, np.zeros_like(theta), "--", color="k", lw=1.0,
            label=f"commanded radius r = {_g(radius * 1e3)} mm (0 µm)")
    ax.plot(theta, np.full_like(theta, mean), ":", color="0.3", lw=1.0,
            label=f"mean deviation {_g(mean)} µm")
    for i, (value, label) in enumerate(limits):
        ax.plot(theta, np.full_like(theta, value), color="C3", lw=1.2,
                label=label if i == 0 or label != limits[i - 1][1] else None)
    ax.plot(angle, dev, color="C0", lw=0.6, label="path (re-simulated)")
    start = angle[0]
    ax.fill_between(np.linspace(start, start + wedge, 50), r_min, r_max, color="C1", alpha=0.35,
                    lw=1.0, edgecolor="C1", label="zoomed below")
    middle = math.degrees(start + wedge / 2) % 360  # labels upright, clear of the wedge
    label_at = 270 if abs(middle - 90) < 45 + math.degrees(wedge) / 2 else 90
    ax.set_rlabel_position(label_at)
    ax.tick_params(axis="y", labelsize=7)
    for label in ax.get_yticklabels():  # readable over the path
        label.set_bbox({"boxstyle": "round,pad=0.1", "fc": "white", "ec": "none", "alpha": 0.8})
    ax.text(math.radians(label_at), r_min - 0.12 * (r_max - r_min), "[µm]", fontsize=8,
            ha="center", va="center")  # in the hole, next to the innermost label
    ax.set_title(f"circle test at {_g(feed * 1e3)} mm/s: radial deviation from the commanded "
                 f"radius [µm]\n(ring not to scale: it spans {_g(r_max - r_min)} µm)",
                 fontsize=10)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.06), ncol=2, fontsize=7,
              frameon=False)
    zoom = figure.add_subplot(grid[1])
    part = angle - start <= wedge
    degrees = np.degrees(angle[part] - start)
    ripple = max(high - low, CIRCLE_MIN_SPAN * UM)
    zoom.set_ylim(low - 0.4 * ripple, high + 0.4 * ripple)
    zoom.axhspan(low, high, color="C0", alpha=0.15, lw=0)
    zoom.plot(degrees, dev[part], color="C0")
    zoom.axhline(mean, color="0.3", ls=":", lw=1.0)
    for value, _ in limits + [(0.0, "")]:
        if low - 0.4 * ripple <= value <= high + 0.4 * ripple:  # only those in view
            zoom.axhline(value, color="C3" if _ else "k", ls="-" if _ else "--", lw=1.0)
    zoom.set_xlabel("angle from the start of the revolution [deg]")
    zoom.set_ylabel("deviation [µm]")
    zoom.grid(True, alpha=0.3)
    for side in zoom.spines.values():
        side.set_color("C1")
        side.set_linewidth(1.5)
    zoom.set_title("zoom on the orange wedge: " + (
        f"first {ZOOM_SIDES} sides of the interpolated polygon" if interval
        else f"first {ZOOM_DEGREES}°"), fontsize=9)
    lines = [f"r = {_g(radius * 1e3)} mm, feed {_g(feed * 1e3)} mm/s",
             f"re-simulated: mean deviation {_g(mean)} µm, circularity (max − min) "
             f"{_g(high - low)} µm"]
    for name, label in (("circle_roughness", "roughness"),
                        ("surface_roughness", "surface roughness (Sato eq 10)"),
                        ("radial_error", "radial error (Koren eq 28)"),
                        ("radius_decrease", "decrease in radius (Sato eq 7)")):
        value = metric(result, name)
        if value is not None:
            lines.append(f"{label} {_g(value * UM)} µm (reported)")
    text = figure.add_subplot(grid[2])
    text.axis("off")
    text.text(0.0, 1.0, "\n".join(lines), fontsize=8, va="top", transform=text.transAxes)
    figure.tight_layout()
    return figure


def poles_figure(model, result: dict) -> Figure:
    """Closed-loop poles: the s-plane, or the z-plane with the unit circle."""
    poles = np.asarray(model.poles(), dtype=complex)
    figure, axes = _figure(1, 1, height=5.5)
    ax = axes[0, 0]
    if model.sampled:
        theta = np.linspace(0, 2 * math.pi, 361)
        ax.plot(np.cos(theta), np.sin(theta), color="0.5", lw=0.8, label="|z| = 1")
        ax.set_aspect("equal")
        ax.set_xlabel("Re z")
        ax.set_ylabel("Im z")
        radius = float(np.max(np.abs(poles)))
        title = f"closed-loop poles, z-plane (spectral radius {radius:.4g})"
    else:
        ax.axvline(0, color="0.5", lw=0.8)
        ax.set_xlabel("Re s [1/s]")
        ax.set_ylabel("Im s [rad/s]")
        title = f"closed-loop poles, s-plane (spectral abscissa {float(np.max(poles.real)):.4g} 1/s)"
        if np.ptp(np.abs(poles)) > 0 and np.max(np.abs(poles)) / max(np.min(np.abs(poles)), 1e-300) > 1e3:
            ax.set_xscale("symlog", linthresh=max(float(np.min(np.abs(poles[poles != 0]),
                                                               initial=1.0)), 1e-9))
    ax.plot(poles.real, poles.imag, "x", ms=9, mew=2, color="C3", label="poles")
    ax.legend(loc="upper left", fontsize=8)
    ax.grid(True, alpha=0.3)
    ax.set_title(title, fontsize=10)
    figure.tight_layout()
    return figure


#: (file stem, title, function) of every figure, in page order
FIGURES = (
    ("responses", "Time responses", responses_figure),
    ("bode", "Frequency response", bode_figure),
    ("circle", "Circle test", circle_figure),
    ("poles", "Closed-loop poles", poles_figure),
)
