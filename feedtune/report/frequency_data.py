"""The report's figures of a result tuned on measured frequency responses (plant
``frequency_response_data``): every data set's measured open loop L = G K at the tuned
gains as a Nyquist plot (with the count of the result's certificate) and as a Bode plot
(crossover and phase margin marked), and |S| and |T| against their bounds.

The curves are the validator's own evaluation at the measured points
(:func:`feedtune.validate.frequency_data.measured_loops`), not the design's; the values
marked on them (margins, counts, bounds) are the result's, so a reader sees whether they
sit where the data say. Between the points nothing is drawn that the data do not give:
markers at the points, joined by straight lines.
"""

from __future__ import annotations

import math

import numpy as np

from feedtune.report.figures import _figure, _g, _note, metric
from feedtune.validate.frequency_data import MeasuredLoop, measured_loops

#: the Nyquist figure shows L around the critical point −1 within this radius [1]
NYQUIST_RADIUS = 3.0
#: |T| is drawn down to this [1]: the peak and the −3 dB point are what matter
T_FLOOR = 1e-2


def _certificates(result: dict) -> dict[str, dict]:
    """The result's Nyquist certificate per set name."""
    return {s.get("name"): s for s in (result.get("stability") or {}).get("sets") or []}


def _count_text(name: str, certificate: dict | None, unstable_poles: int) -> str:
    """``name: 1 + L turns π (π expected), N = 0 clockwise encirclements of −1, Z = 0``."""
    if not certificate or certificate.get("phase_change_rad") is None:
        reason = (certificate or {}).get("reason", "no certificate")
        return f"{name}: not counted ({reason[:60]})"
    turn = certificate["phase_change_rad"] / math.pi
    expected = certificate["expected_phase_change_rad"] / math.pi
    poles = certificate["unstable_closed_loop_poles"]
    encirclements = poles - unstable_poles  # Z = N + P
    return (f"{name}: 1 + L turns {turn:.3g}π ({expected:.3g}π expected); "
            f"N = {encirclements} encirclement(s) of −1, P = {unstable_poles}, Z = {poles}")


def nyquist_figure(loops: list[MeasuredLoop], result: dict):
    """L(jω) of every set at its measured points near −1, the unit circle, and each set's
    Nyquist count as the result's certificate made it (Z = N + P)."""
    figure, axes = _figure(height=6.0)
    ax = axes[0][0]
    plant = result["spec"]["plant"]
    certificates = _certificates(result)
    for loop in loops:
        l = loop.loop
        near = np.abs(l + 1.0) <= NYQUIST_RADIUS
        shown = np.where(near, l, np.nan)
        ax.plot(shown.real, shown.imag, ".-", ms=2, lw=0.8,
                label=_count_text(loop.name, certificates.get(loop.name),
                                  plant.get("unstable_poles", 0)))
    circle = np.exp(1j * np.linspace(0, 2 * math.pi, 361))
    ax.plot(circle.real, circle.imag, ":", color="grey", lw=0.8)
    ax.plot([-1.0], [0.0], "x", color="red", ms=9, mew=2)
    ax.set_xlim(-1.0 - NYQUIST_RADIUS, -1.0 + NYQUIST_RADIUS)
    ax.set_ylim(-NYQUIST_RADIUS, NYQUIST_RADIUS)
    ax.set_aspect("equal")
    ax.axhline(0.0, color="black", lw=0.5)
    ax.axvline(0.0, color="black", lw=0.5)
    ax.set_xlabel("Re L [1]")
    ax.set_ylabel("Im L [1]")
    ax.set_title("Measured open loop L = G K (Nyquist, measured points near −1)")
    ax.legend(loc="upper left", fontsize=7)
    stable = (result.get("stability") or {}).get("stable")
    _note(ax, [f"certified {'stable' if stable else 'NOT stable'} by the Nyquist count",
               f"band {_g(loops[0].omega[0])}–{_g(loops[0].omega[-1])} rad/s"])
    return figure


def bode_figure(loops: list[MeasuredLoop], result: dict):
    """|L| and the phase of L of every set against ω, with each set's reported crossover
    ω_c and phase margin marked."""
    figure, axes = _figure(2, 1, height=6.5)
    mag, phase = axes[0][0], axes[1][0]
    for loop in loops:
        l = loop.loop
        line, = mag.loglog(loop.omega, np.abs(l), ".-", ms=1.5, lw=0.8, label=loop.name)
        unwrapped = np.degrees(np.unwrap(np.angle(l)))
        unwrapped -= 360.0 * round(unwrapped[0] / 360.0)  # the branch nearest 0 at the bottom
        phase.semilogx(loop.omega, unwrapped, ".-", ms=1.5, lw=0.8, color=line.get_color())
        crossover = metric(result, "crossover_frequency", set=loop.name)
        margin = metric(result, "phase_margin", set=loop.name)
        if crossover is not None:
            mag.axvline(crossover, color=line.get_color(), ls="--", lw=0.7)
            phase.axvline(crossover, color=line.get_color(), ls="--", lw=0.7)
            if margin is not None:
                at = float(np.interp(math.log(crossover), np.log(loop.omega), unwrapped))
                phase.plot([crossover, crossover], [at, at - margin], "-", lw=2.5,
                           color=line.get_color(), alpha=0.6,
                           label=f"{loop.name}: ω_c {_g(crossover)} rad/s, PM {_g(margin)}°")
    mag.axhline(1.0, color="black", lw=0.6)
    phase.axhline(-180.0, color="black", lw=0.6)
    mag.set_ylabel("|L| [1]")
    phase.set_ylabel("phase of L [deg]")
    phase.set_xlabel("ω [rad/s]")
    mag.set_title("Measured open loop L = G K (Bode), crossover and phase margin")
    mag.legend(loc="lower left", fontsize=7)
    phase.legend(loc="lower left", fontsize=7)
    return figure


def sensitivity_figure(loops: list[MeasuredLoop], result: dict):
    """|S| and |T| of every set against ω with the spec's bounds (M_s, M_peak, and 1/|W|
    of the weighted sensitivity), and each set's reported bandwidth."""
    figure, axes = _figure(2, 1, height=6.5)
    top, bottom = axes[0][0], axes[1][0]
    bounds = {c["metric"]: c["max"] for c in result["spec"].get("constraints") or []}
    for loop in loops:
        magnitudes = loop.magnitudes()
        line, = top.loglog(loop.omega, magnitudes["sensitivity_peak"], ".-", ms=1.5, lw=0.8,
                           label=loop.name)
        bottom.loglog(loop.omega, magnitudes["m_peak"], ".-", ms=1.5, lw=0.8,
                      color=line.get_color(), label=loop.name)
        bandwidth = metric(result, "bandwidth", set=loop.name)
        if bandwidth is not None:
            bottom.axvline(bandwidth, color=line.get_color(), ls="--", lw=0.7)
    omega = loops[0].omega
    if "sensitivity_peak" in bounds:
        top.axhline(bounds["sensitivity_peak"], color="red", lw=1.0,
                    label=f"bound M_s = {_g(bounds['sensitivity_peak'])}")
    if loops[0].weight is not None:
        top.loglog(omega, 1.0 / loops[0].weight, "--", color="red", lw=1.0,
                   label="1/|W| (weighted sensitivity)")
    if "m_peak" in bounds:
        bottom.axhline(bounds["m_peak"], color="red", lw=1.0,
                       label=f"bound M_peak = {_g(bounds['m_peak'])}")
    bottom.axhline(1.0 / math.sqrt(2.0), color="grey", ls=":", lw=0.8, label="−3 dB")
    bottom.set_ylim(bottom=T_FLOOR)
    top.set_ylabel("|S| [1]")
    bottom.set_ylabel("|T| [1]")
    bottom.set_xlabel("ω [rad/s]")
    top.set_title("Sensitivity |S| and complementary sensitivity |T| on every data set")
    top.legend(loc="lower right", fontsize=7)
    bottom.legend(loc="lower left", fontsize=7)
    return figure


#: the figures of a data-driven result: (stem, title, drawing function)
FIGURES = (
    ("measured_nyquist", "Measured open loop (Nyquist)", nyquist_figure),
    ("measured_bode", "Measured open loop (Bode)", bode_figure),
    ("measured_sensitivity", "Sensitivity and complementary sensitivity", sensitivity_figure),
)


def figures_of(result: dict, png) -> list[tuple[str, str, bytes | None, str | None]]:
    """(stem, title, PNG bytes or None, why not) of every figure; ``png`` turns a Figure
    into bytes."""
    tuned = {name: t["value"] for name, t in (result.get("tuned") or {}).items()}
    if not tuned:
        return [(stem, title, None, "nothing was tuned") for stem, title, _ in FIGURES]
    loops = measured_loops(result["spec"], tuned)
    return [(stem, title, png(draw(loops, result)), None) for stem, title, draw in FIGURES]
