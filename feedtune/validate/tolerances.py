"""How each validated metric is judged: one table, metric → tolerance and physical scale.

A gap is |reported − validated| in the metric's own unit. It is within tolerance when

    gap ≤ max(rel·|validated|, fraction·scale)

where ``scale`` is a physical quantity of the axis (a BLU, a time constant, a step size),
never the value itself: a radial error of 1e-15 m and one of 2e-15 m are the same circle,
and a relative comparison of them is noise. ``rel`` covers what the two computations
differ by in relative terms (the validator's quadrature, the tuner's grid); ``fraction ·
scale`` is the smallest gap that would matter physically. The table is documented in
docs/validation.md; :func:`judge` is the only place an entry's ``ok`` is decided, and
``feedtune tune`` (warnings) and ``feedtune batch`` (failures) both read that ``ok``.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

from feedtune.schema.model import json_number


@dataclass(frozen=True)
class Rule:
    """``rel`` [1] of |validated|, or ``fraction`` [1] of the physical scale ``scale``."""

    rel: float
    scale: str
    fraction: float
    why: str


@dataclass(frozen=True)
class Context:
    """The physical scales a validator model knows of its axis.

    blu : float or None
        Basic length unit [m] (software servo), None when the spec has none.
    time : float or None
        The loop's slowest time constant 1/min|p| [s] over its s-plane poles (z-plane
        poles through s = ln z / T), None where there are no poles (pulse generator).
    period : float or None
        The pulse generator's period 1/f [s].
    pulse : float or None
        Position of one pulse δ [m or rad] (pulse generator).
    position_unit : str
        "m" or "rad".
    """

    blu: float | None = None
    time: float | None = None
    period: float | None = None
    pulse: float | None = None
    position_unit: str = "m"


#: relative-only: for quantities that are positive by construction (frequencies, gains,
#: time constants); ``fraction`` is then unused
RELATIVE = "relative"

#: metric (or ``metric(option)``) → how it is judged
RULES: dict[str, Rule] = {
    # -- lengths on a circle: the axis' resolution -----------------------------------------
    "radial_error": Rule(1e-6, "resolution", 1e-3,
                         "a length: BLU/1000 is 0.2 % of Koren's BLU/2 criterion (eqs 30–32), "
                         "far above rounding (1e-16·r) and far below anything a machine shows"),
    "radius_decrease": Rule(1e-6, "resolution", 1e-3, "a length on the circle, as radial_error"),
    "average_radius": Rule(1e-9, "resolution", 1e-3, "a length on the circle, as radial_error"),
    "circle_mean_deviation": Rule(1e-5, "resolution", 1e-3,
                                  "a length on the circle; rel: the mean of a periodic signal by "
                                  "trapezoid on both sides (measured 6e-7 on sato-finish)"),
    "circularity": Rule(2e-2, "resolution", 1e-3,
                        "a length on the circle; rel: peaks and valleys on the tuner's 16 "
                        "points per sample, (π/(16q))²/2 of the ripple (1.9 % at q = 1, "
                        "measured 1.8e-5 at q = 5); a q that is not whole the tuner takes "
                        "as its nearest a/b, b ≤ 16 (measured 5e-4 on sato-throughput)"),
    "circle_roughness": Rule(2e-2, "resolution", 1e-3, "as circularity"),
    # the radius change that moves the error at V_m by BLU/1000 (computed by the model)
    "min_radius": Rule(1e-9, "criterion", 1.0,
                       "the radii where the error at V_m is BLU/2 ± BLU/1000: a gap is a "
                       "disagreement only if it moves the criterion by more than BLU/1000"),
    # -- step and ramp integrals: step size × the loop's time scale --------------------------
    "iae": Rule(1e-4, "integral", 1e-6,
                "1 (m or rad) × t^p, t the slowest time constant: the natural size of the "
                "integral; rel: the validator's trapezoid, ~(h·ω)²/12 with h ≤ T/256 "
                "(sampled, measured 4e-8 … 1e-6, the 276 Hz mode of the sampled user "
                "example) or 0.01/|p| (continuous, ≈ 1e-5); the software servo's are "
                "exact per sample (≤ 2.1e-12 from the tuner's exact values on 300 batch "
                "specs)"),
    "ise": Rule(1e-4, "integral", 1e-6, "as iae"),
    "itae": Rule(1e-4, "integral", 1e-6, "as iae"),
    "load_rejection(iae)": Rule(1e-4, RELATIVE, 0.0,
                                "a load step always deflects the axis, so the integral is "
                                "positive; rel: trapezoid on the graded grid"),
    # -- dimensionless ------------------------------------------------------------------
    "damping_ratio": Rule(1e-6, "unity", 1e-6, "ζ is of order 1; eigenvalues on both sides"),
    "m_peak": Rule(1e-6, "unity", 1e-6, "|H/H(0)| ≥ 1; Brent on exact expressions on both sides"),
    "sensitivity_peak": Rule(1e-6, "unity", 1e-6,
                             "|S| → 1 as ω → ∞, so M_s is of order 1; as m_peak"),
    "pole_damping": Rule(1e-6, "unity", 1e-6,
                         "ζ is of order 1; eigenvalues on both sides, as damping_ratio"),
    # a scale the model computes ("criterion"): the magnitude |p| of the pole that sets it
    # (feedtune.validate.poles)
    "decay_rate": Rule(1e-6, "criterion", 1e-6,
                       "a rate from one pole's real part: an eigenvalue's rounding is "
                       "relative to its magnitude, 1e-6·|p| as the poles entry"),
    "overshoot": Rule(1e-6, "unity", 1e-6,
                      "a fraction of the unit step; 0 when there is none, so never relative"),
    "gain_margin": Rule(1e-6, RELATIVE, 0.0, "a ratio > 0; +∞ without a phase crossover"),
    "phase_margin": Rule(1e-6, "half_turn", 1e-6, "an angle: 180° is its natural scale"),
    # -- frequencies, gains, times that are positive --------------------------------------
    "natural_frequency": Rule(1e-6, RELATIVE, 0.0, "a pole's magnitude > 0"),
    "velocity_constant": Rule(1e-6, RELATIVE, 0.0, "C_v > 0 of a type-1 loop; a linear solve"),
    "bandwidth": Rule(1e-6, RELATIVE, 0.0, "a frequency > 0; Brent on both sides"),
    "crossover_frequency": Rule(1e-6, RELATIVE, 0.0, "a frequency > 0; Brent on both sides"),
    "sensitivity": Rule(1e-9, RELATIVE, 0.0, "a gain > 0; a linear solve on each side"),
    "settling_time": Rule(1e-6, "time", 1e-6,
                          "a time: the slowest time constant; 0 when the error never leaves "
                          "the band"),
    "load_rejection(peak)": Rule(1e-6, RELATIVE, 0.0,
                                 "the peak deflection per N·m ≥ the static one > 0"),
    # -- the pulse generator: the same integer arithmetic on both sides ---------------------
    "pulse_rise_time": Rule(1e-9, "period", 1e-9, "a time: one period 1/f"),
    "pulse_settling_time": Rule(1e-9, "period", 1e-9, "a time: one period 1/f"),
    "pulse_overshoot": Rule(1e-9, "pulse_count", 1e-9, "a count of pulses: one pulse"),
    "pulse_final_error": Rule(1e-9, "pulse", 1e-9, "a position: one pulse δ"),
    "sine_tracking_error": Rule(1e-9, "pulse", 1e-9, "a position: one pulse δ"),
    "pulse_max_velocity": Rule(1e-9, "pulse_velocity", 1e-9, "a velocity: one pulse per period, δf"),
    "peak_commanded_acceleration": Rule(1e-9, "pulse_acceleration", 1e-9,
                                        "an acceleration: δf² (one pulse per period, per period)"),
    "peak_measured_acceleration": Rule(1e-9, "pulse_acceleration", 1e-9, "as commanded"),
    "motor_acceleration_margin": Rule(1e-9, "unity", 1e-9, "a fraction of the motor's capacity"),
}

#: the per-revolution resolution assumed on a circle when the spec gives no BLU: 1 µm per
#: metre of radius (0.05 µm on a 50 mm circle, finer than the encoders of the papers)
RADIUS_RESOLUTION = 1e-6

#: time powers of the integrals after a unit step (a ramp adds one)
_TIME_POWER = {"iae": 1, "ise": 1, "itae": 2}


def rule_key(metric: str, options: dict) -> str:
    """The table's key: ``load_rejection(peak|iae)``, else the metric's name."""
    if metric == "load_rejection":
        return f"load_rejection({options.get('measure', 'peak')})"
    return metric


def scale_of(kind: str, metric: str, options: dict, context: Context) -> tuple[float, str]:
    """(value in the metric's unit, label) of the physical scale ``kind``.

    Raises
    ------
    ValueError
        When the model's context lacks the quantity (a programming error: every model
        declares what its metrics need).
    """
    unit = context.position_unit
    if kind == RELATIVE:
        return 0.0, "relative"
    if kind == "unity":
        return 1.0, "1"
    if kind == "half_turn":
        return 180.0, "180°"
    if kind == "resolution":
        if context.blu is not None:
            return context.blu, "BLU"
        return RADIUS_RESOLUTION * options["radius"], f"{RADIUS_RESOLUTION:g}·r"
    if kind == "integral":
        if options.get("time", "absolute") == "natural":  # ω_n·t is dimensionless
            return 1.0, f"1 {unit}·rad^p"
        power = _TIME_POWER[metric] + (options.get("input", "step") == "ramp")
        return _need(context.time, kind) ** power, f"1 {unit}·t^{power} (t = 1/min|p|)"
    if kind == "time":
        return _need(context.time, kind), "t = 1/min|p|"
    if kind == "period":
        return _need(context.period, kind), "1/f"
    if kind == "pulse_count":
        return 1.0, "1 pulse"
    if kind == "pulse":
        return _need(context.pulse, kind), "δ"
    if kind == "pulse_velocity":
        return _need(context.pulse, kind) / _need(context.period, kind), "δf"
    if kind == "pulse_acceleration":
        return _need(context.pulse, kind) / _need(context.period, kind) ** 2, "δf²"
    raise ValueError(f"unknown scale {kind!r}")


def _need(value: float | None, kind: str) -> float:
    if value is None:
        raise ValueError(f"the model gives no {kind} scale")
    return value


@functools.cache
def _label(fraction: float, label: str) -> str:
    """``BLU/1000``, ``1e-06`` (of 1), ``1e-06·180°``: the absolute tolerance's name."""
    if label == "relative" or fraction == 1:
        return label
    if label == "1":
        return f"{fraction:g}"
    inverse = 1 / fraction
    if inverse <= 1e4 and abs(inverse - round(inverse)) < 1e-9 * inverse:
        return f"{label}/{round(inverse)}"
    return f"{fraction:g}·{label}"


def judge(record: dict, validated: float, context: Context,
          scale: tuple[float, str] | None = None) -> dict:
    """The validation entry of a result's metric ``record`` (``metric``, ``options``,
    ``value``, ``unit``) re-measured as ``validated``.

    ``scale``: (value, label) for a rule whose scale the model computes itself
    (``criterion``: min_radius). The entry holds ``gap`` = |reported − validated| and
    ``tolerance`` = max(rel·|validated|, fraction·scale), both in ``unit``; ``basis`` says
    which of the two set the tolerance ("BLU/1000", "1e-06 × |value|"). An infinite value
    (a run that never settles, a gain margin without a phase crossover) has no gap: ``ok``
    when both are infinite alike; the entry then holds ±∞ as the strings "Infinity" /
    "-Infinity" (:func:`feedtune.schema.model.json_number`), and no tolerance when the
    validated value is the infinite one.
    """
    metric, options = record["metric"], record.get("options") or {}
    reported = record["value"]
    rule = RULES[rule_key(metric, options)]
    if scale is None:
        scale = scale_of(rule.scale, metric, options, context)
    absolute = rule.fraction * scale[0]
    relative = rule.rel * abs(validated)
    tolerance = max(relative, absolute)
    basis = _label(rule.fraction, scale[1]) if absolute >= relative else f"{rule.rel:g} × |value|"
    row = {"metric": metric, "options": options, "reported": reported, "validated": validated,
           "unit": record.get("unit"), "gap": None, "tolerance": tolerance, "basis": basis}
    if math.isinf(reported) or math.isinf(validated):  # a run that never settles, a gain
        # margin without a phase crossover: ±∞ as a result's JSON carries it
        return {**row, "reported": json_number(reported), "validated": json_number(validated),
                "tolerance": tolerance if math.isfinite(tolerance) else None,
                "ok": reported == validated}
    gap = abs(reported - validated)
    return {**row, "gap": gap, "ok": bool(gap <= tolerance)}
