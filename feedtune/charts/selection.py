"""Koren 1979's choice of CNC technique (Fig 9 and the Summary) and its design numbers.

Reference-pulse is possible while the interpolator keeps up, f_m = V_m/BLU ≤ 1/t_e
(eqs 1–2, t_e ≈ 100 µs ⇒ 10⁴ pulses/s). Sampled-data is possible when the encoder still
delivers f_m/f_s ≥ 100 pulses per sample (eq 26) at the recommended period T ≈ (π/4)τ
(eq 23), i.e. τ f_m ≥ 400/π (eq 27). Given the choice, reference-pulse is preferred for
its simplicity (Summary). Gains: K = 1/(2τ) for reference-pulse (eq 11); for sampled-data
K = 1/(T + 2τ) (eq 40, minimum radial error, contouring) or the minimum-IAE gain of
Fig 6 (linear motions only, found by tuning). Minimum allowable radius at V_m: eq 39 with
the coefficient 4^(1/3) (docs/errata.md), eq 32, and feedtune's exact ``min_radius``.

References
----------
Y. Koren, "Design of Computer Control for Manufacturing Systems", ASME J. Eng. Ind.
101(3), 1979, pp. 326–332: eqs 1, 2, 11, 23, 26, 27, 32, 39, 40, Figs 8 and 9, Summary.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

#: eq 2: execution time of one interpolator iteration [s] (10⁴ pulses/s)
EXECUTION_TIME = 1e-4
#: eq 26: encoder pulses per sample at V_m, f_m/f_s [1]
ENCODER_RATIO = 100.0
#: eq 23: sampling period over time constant, T/τ [1]
SAMPLING_RATIO = math.pi / 4
#: eq 39 as corrected (docs/errata.md): r/BLU = 4^(1/3) (τ f_m)^(4/3)
EQ39_COEFFICIENT = 4 ** (1 / 3)

REFERENCE_PULSE, SAMPLED_DATA = "reference_pulse", "sampled_data"
#: relative slack of the eq 2 and eq 27 comparisons, so that a design exactly on a boundary
#: (0.1 m/s over 1e-5 m is 10⁴ pulses/s only up to rounding) counts as on the allowed side
RTOL = 1e-12


def max_pulse_rate(blu: float, max_velocity: float) -> float:
    """f_m = V_m/BLU [pulses/s] (Koren eq 1)."""
    return max_velocity / blu


def reference_pulse_applicable(pulse_rate: float, execution_time: float = EXECUTION_TIME) -> bool:
    """Eq 2: the interpolator emits at most one pulse per iteration, f_m ≤ 1/t_e."""
    return pulse_rate <= (1 / execution_time) * (1 + RTOL)


def sampled_data_applicable(time_constant: float, pulse_rate: float,
                            encoder_ratio: float = ENCODER_RATIO,
                            sampling_ratio: float = SAMPLING_RATIO) -> bool:
    """Eq 27 (eqs 23 and 26 combined): τ f_m ≥ (f_m/f_s)/(T/τ), 400/π for Koren's numbers."""
    return time_constant * pulse_rate >= (encoder_ratio / sampling_ratio) * (1 - RTOL)


def region(time_constant: float, pulse_rate: float, execution_time: float = EXECUTION_TIME,
           encoder_ratio: float = ENCODER_RATIO, sampling_ratio: float = SAMPLING_RATIO) -> str:
    """Fig 9's region of (τ, f_m): ``either``, ``reference_pulse``, ``sampled_data`` or ``none``."""
    rp = reference_pulse_applicable(pulse_rate, execution_time)
    sd = sampled_data_applicable(time_constant, pulse_rate, encoder_ratio, sampling_ratio)
    return {(True, True): "either", (True, False): REFERENCE_PULSE,
            (False, True): SAMPLED_DATA, (False, False): "none"}[(rp, sd)]


def eq39_min_radius(time_constant: float, blu: float, pulse_rate: float) -> float:
    """Reference-pulse minimum radius at K = 1/(2τ) [m]: eq 39 with 4^(1/3) (errata)."""
    return blu * EQ39_COEFFICIENT * (time_constant * pulse_rate) ** (4 / 3)


def eq32_min_radius(gain: float, period: float, time_constant: float, blu: float,
                    pulse_rate: float) -> float:
    """Eq 32 with eq 29: r = BLU·L·(T f_m)² [m] (0 on the eq 40 locus, where L = 0).
    With T = 0 this is eq 33: BLU·(2Kτ − 1)(f_m/K)²."""
    k, t, tau = gain, period, time_constant
    if t == 0:
        return blu * max(2 * k * tau - 1, 0.0) * (pulse_rate / k) ** 2
    numerator = k * tau * (t / tau + 2) - 1
    if abs(numerator) < 1e-12 * k * tau * (t / tau + 2):  # on the eq 40 locus: L = 0 exactly
        numerator = 0.0
    return blu * max(numerator / (k * t) ** 2, 0.0) * (t * pulse_rate) ** 2


@dataclass
class Design:
    """One technique's design: gain, period and minimum radius, all SI."""

    technique: str
    applicable: bool
    reason: str
    gain: float | None = None              # K [1/s]
    gain_rule: str = ""
    sampling_period: float | None = None   # T [s]
    sampling_frequency: float | None = None  # f_s [Hz]
    encoder_ratio: float | None = None     # f_m/f_s [1]
    damping_ratio: float | None = None     # ζ [1]
    min_radius: float | None = None        # exact [m]
    min_radius_formula: float | None = None  # eq 39 / eq 32 [m]
    min_radius_rule: str = ""


@dataclass
class Recommendation:
    time_constant: float
    blu: float
    max_velocity: float
    pulse_rate: float
    radius: float | None
    motion: str
    region: str
    technique: str | None
    reason: str
    designs: dict[str, Design] = field(default_factory=dict)
    radius_ok: bool | None = None
    notes: list[str] = field(default_factory=list)
    execution_time: float = EXECUTION_TIME      # t_e [s] (eq 2)
    encoder_ratio_min: float = ENCODER_RATIO    # f_m/f_s bound [1] (eq 26)
    sampling_ratio: float = SAMPLING_RATIO      # T/τ [1] (eq 23)

    def as_dict(self) -> dict:
        return asdict(self)


def sampling_period_for(time_constant: float, pulse_rate: float, sampling_ratio: float,
                        encoder_ratio: float, rounding: str) -> float:
    """T = (T/τ)·τ (eq 23); with ``rounding="power-of-two"`` f_s = 1/T becomes the nearest
    power of two (Koren's 62.5 → 64 Hz) that still keeps f_m/f_s ≥ the encoder ratio."""
    period = sampling_ratio * time_constant
    if rounding == "power-of-two":
        frequency = 2.0 ** round(math.log2(1 / period))
        while pulse_rate / frequency < encoder_ratio * (1 - 1e-12) and frequency > 2 ** -30:
            frequency /= 2
        period = 1 / frequency
    return period


def _exact(technique: str, gain: float, period: float | None, time_constant: float,
           blu: float, max_velocity: float) -> dict:
    """Every metric at a fixed design, by feedtune itself (a spec with nothing free)."""
    from feedtune.problem import tune
    from feedtune.schema.spec import parse_spec

    tunables = {"position_gain": {"value": gain}}
    if period is not None:
        tunables["sampling_period"] = {"value": period}
    spec = {"name": "select-check",
            "plant": {"type": "software_servo", "technique": technique,
                      "time_constant": time_constant, "blu": blu, "max_velocity": max_velocity},
            "tunables": tunables, "objective": [{"metric": "damping_ratio"}]}
    result = tune(parse_spec(spec))
    return {name: value.value for name, value in result.metrics.items()}


def _min_iae_gain(period: float, time_constant: float) -> float:
    """The minimum-IAE gain of Fig 6 (natural time, as Koren's locus) at period T, tuned."""
    from feedtune.charts.koren import tune_point

    point = tune_point("min_iae", time_constant, period / time_constant)
    if point["gain"] is None:
        raise RuntimeError(f"the minimum-IAE tuning did not succeed: {point['status']}")
    return point["gain"]


def recommend(time_constant: float, blu: float, max_velocity: float, radius: float | None = None,
              motion: str = "contouring", execution_time: float = EXECUTION_TIME,
              encoder_ratio: float = ENCODER_RATIO, sampling_ratio: float = SAMPLING_RATIO,
              rounding: str = "none") -> Recommendation:
    """Koren's Summary as a procedure: technique, K [1/s], T [s], f_s [Hz], minimum radius [m].

    ``motion``: ``contouring`` (lines and circles: minimum radial error, eqs 11/40) or
    ``linear`` (minimum IAE, Fig 6, for sampled-data; reference-pulse keeps eq 11, as the
    Summary prescribes). ``radius`` [m]: the smallest radius the part needs at V_m; the
    recommendation says whether the design's minimum allowable radius meets it.
    """
    tau, f_m = time_constant, max_pulse_rate(blu, max_velocity)
    where = region(tau, f_m, execution_time, encoder_ratio, sampling_ratio)
    limit = 1 / execution_time
    bound27 = encoder_ratio / sampling_ratio
    designs = {}

    rp_ok = reference_pulse_applicable(f_m, execution_time)
    rp = Design(REFERENCE_PULSE, rp_ok,
                f"eq 2: f_m = {f_m:.6g} pulses/s {'≤' if rp_ok else '>'} 1/t_e = {limit:.6g} pulses/s")
    if rp_ok:
        rp.gain, rp.gain_rule = 1 / (2 * tau), "eq 11: K = 1/(2τ)"
        exact = _exact(REFERENCE_PULSE, rp.gain, None, tau, blu, max_velocity)
        rp.damping_ratio = exact.get("damping_ratio")
        rp.min_radius = exact.get("min_radius")
        rp.min_radius_formula = eq39_min_radius(tau, blu, f_m)
        rp.min_radius_rule = "eq 39 with 4^(1/3), docs/errata.md"
    designs[REFERENCE_PULSE] = rp

    sd_ok = sampled_data_applicable(tau, f_m, encoder_ratio, sampling_ratio)
    sd = Design(SAMPLED_DATA, sd_ok,
                f"eq 27: τ f_m = {tau * f_m:.6g} {'≥' if sd_ok else '<'} (f_m/f_s)/(T/τ) = {bound27:.6g}")
    if sd_ok:
        period = sampling_period_for(tau, f_m, sampling_ratio, encoder_ratio, rounding)
        sd.sampling_period, sd.sampling_frequency = period, 1 / period
        sd.encoder_ratio = f_m * period
        if motion == "linear":
            sd.gain, sd.gain_rule = _min_iae_gain(period, tau), "Fig 6: minimum IAE in natural time, tuned"
        else:
            sd.gain, sd.gain_rule = 1 / (period + 2 * tau), "eq 40: K = 1/(T + 2τ)"
        exact = _exact(SAMPLED_DATA, sd.gain, period, tau, blu, max_velocity)
        sd.damping_ratio = exact.get("damping_ratio")
        sd.min_radius = exact.get("min_radius")
        sd.min_radius_formula = eq32_min_radius(sd.gain, period, tau, blu, f_m)
        sd.min_radius_rule = "eq 32, L from eq 29 (0 on the eq 40 locus)"
    designs[SAMPLED_DATA] = sd

    notes = []
    if where == "either":
        technique = REFERENCE_PULSE
        reason = ("either technique applies (Fig 9); reference-pulse is preferred for its "
                  "simplicity (Summary)")
    elif where == REFERENCE_PULSE:
        technique, reason = REFERENCE_PULSE, "only reference-pulse applies: the time constant is too short for sampled-data (eq 27)"
    elif where == SAMPLED_DATA:
        technique, reason = SAMPLED_DATA, "only sampled-data applies: f_m exceeds the interpolator's pulse rate (eq 2)"
    else:
        technique, reason = None, ("neither technique applies: f_m exceeds the interpolator's pulse rate "
                                   "(eq 2) and τ f_m is below eq 27's bound; a coarser BLU, a lower V_m or a faster interpolator (shorter t_e) is needed")
    radius_ok = None
    if radius is not None and technique is not None:
        chosen = designs[technique]
        radius_ok = chosen.min_radius is not None and chosen.min_radius <= radius
        if not radius_ok:
            other = designs[SAMPLED_DATA if technique == REFERENCE_PULSE else REFERENCE_PULSE]
            if other.applicable and other.min_radius is not None and other.min_radius <= radius:
                notes.append(f"{technique} cannot cut r = {radius:.6g} m at V_m (minimum "
                             f"{chosen.min_radius:.6g} m); {other.technique} can "
                             f"(minimum {other.min_radius:.6g} m)")
                technique, radius_ok = other.technique, True
                reason += f"; switched to {other.technique} for the radius"
            else:
                notes.append(f"no applicable design cuts r = {radius:.6g} m at V_m = "
                             f"{max_velocity:.6g} m/s within BLU/2: slow down on that arc")
    if motion == "linear" and technique == SAMPLED_DATA:
        notes.append("minimum-IAE gains give large minimum radii (Fig 8): for circles use "
                     "--motion contouring")
    return Recommendation(tau, blu, max_velocity, f_m, radius, motion, where, technique,
                          reason, designs, radius_ok, notes, execution_time, encoder_ratio,
                          sampling_ratio)


def spec_for(rec: Recommendation, name: str | None = None) -> dict:
    """A spec ``feedtune tune`` accepts that tunes the recommended design.

    Contouring: minimum radial error on the circle of ``radius`` (or the design's minimum
    radius) at V_m, with ζ ≥ 0.5; linear: minimum IAE in natural time. Sampled-data fixes
    T at the recommendation and keeps f_m/f_s ≥ the encoder ratio as a constraint.
    """
    if rec.technique is None:
        raise ValueError("no technique applies, so there is no spec to emit")
    design = rec.designs[rec.technique]
    tau = rec.time_constant
    tunables: dict = {"position_gain": {"min": round(0.05 / tau, 12), "max": round(5 / tau, 12),
                                        "initial": design.gain}}
    constraints: list = []
    if rec.technique == SAMPLED_DATA:
        tunables["sampling_period"] = {"value": design.sampling_period}
        constraints.append({"metric": "encoder_ratio", "min": rec.encoder_ratio_min})
    if rec.motion == "linear":
        objective = [{"metric": "iae", "time": "natural"}]
    else:
        circle = rec.radius if rec.radius is not None else design.min_radius
        objective = [{"metric": "radial_error", "radius": circle, "feed": rec.max_velocity}]
        constraints.append({"metric": "damping_ratio", "min": 0.5})
    spec = {
        "name": name or f"koren-select-{rec.technique.replace('_', '-')}",
        "description": (f"Emitted by feedtune select (Koren 1979 Summary): {rec.technique}, "
                        f"tau = {tau:g} s, BLU = {rec.blu:g} m, V_m = {rec.max_velocity:g} m/s; "
                        f"{design.gain_rule} gives K = {design.gain:.6g} 1/s."),
        "plant": {"type": "software_servo", "technique": rec.technique, "time_constant": tau,
                  "blu": rec.blu, "max_velocity": rec.max_velocity},
        "tunables": tunables,
        "objective": objective,
        "solver": {"multistart": 4},
    }
    if constraints:
        spec["constraints"] = constraints
    return spec
