"""Fixed-order controller design directly on measured frequency responses, by convex
optimisation (cvxpy, the Clarabel SOCP solver): no plant model.

The controller is linear in its parameters over a fixed denominator,

    K(s) = ρᵀφ(s),   φ = [1, 1/s, s/(τ_f s + 1)] (P, PI, PD or PID; τ_f fixed),

so on every measured frequency ω_i of every data set k the open loop L = G_k K is affine in
ρ: L_i(ρ) = a_iᵀρ with a_i = G_k(jω_i)φ(jω_i). The closed-loop magnitude bounds

    |T| = |L|/|1 + L| ≤ M        (M_peak)         ⇔  |L| ≤ M |1 + L|
    |S| = 1/|1 + L| ≤ M_s        (M_s)            ⇔  1 ≤ M_s |1 + L|

are not convex in ρ (|1 + L| is on the larger side). Around a stabilising controller ρ_c,
with X = 1 + L and X_c = 1 + L_c, Re{X_c* X}/|X_c| ≤ |X| (Cauchy–Schwarz), with equality
at ρ = ρ_c, so

    |L| ≤ M Re{X_c* X}/|X_c|,    1 ≤ M_s Re{X_c* X}/|X_c|                (1)

are second-order cone (and linear) constraints whose every solution meets the true bounds,
and ρ_c is one of them (Karimi & Kammer 2017, §3.2; Karimi, Nicoletti & Zhu 2018, eq 14).
They also give Re{X_c* X} > 0 at every ω: X(jω) never turns by π against X_c(jω), so 1 + L
and 1 + L_c wind equally around 0 and, the controller's poles being fixed, the new loop
is stable when ρ_c's is (the same papers' stability lemma, on the measured band).

The objective is a bandwidth, kept convex the same way: |T| ≥ 1/√2 up to ω_b (the −3 dB
point of feedtune's ``bandwidth``) holds when

    Re{L_c* L}/|L_c| ≥ |1 + L|/√2    for every measured ω ≤ ω_b,          (2)

or a crossover, |L| ≥ 1 up to ω_c: Re{L_c* L}/|L_c| ≥ 1. ω_b is the largest measured
frequency for which (1) and (2) have a solution: found by an exponential search then
bisection over the measured frequencies, each a feasibility SOCP written as "maximise the
smallest slack s of (2)" (feasible when s ≥ 0; always solvable, since ρ_c is a point of
it). The solution's controller becomes the next ρ_c, and the iteration stops when ω_b no
longer grows and ρ moves less than ``tol`` (relative). Every iterate meets the bounds and
is stable, so stopping early still leaves a valid design.

Stability is certified from the data (:func:`nyquist_certificate`): the phase of 1 + L
across each measured band plus the two unmeasured ends, against the Nyquist count
(n + 2P)·π/2 for n integrators of the loop and P unstable poles of the plant.

References
----------
A. Karimi, C. Kammer, "A data-driven approach to robust control of multivariable systems
by convex optimization", Automatica 85 (2017) 227–233, §3 (the linearisation around K_c,
the stability lemma).
A. Karimi, A. Nicoletti, Y. Zhu, "Robust H∞ controller design using frequency-domain
data via convex optimization", Int. J. Robust Nonlinear Control 28 (2018) 3766–3783, eq 14.
G. F. Franklin, J. D. Powell, A. Emami-Naeini, "Feedback Control of Dynamic Systems",
§6.3 (the Nyquist criterion, Z = N + P).
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass, field
from typing import Literal, Mapping, Sequence

import numpy as np

from feedtune.schema.status import INFEASIBLE, ITERATION_LIMIT, OPTIMAL, TIME_LIMIT

Law = Literal["p", "pi", "pd", "pid"]
Objective = Literal["bandwidth", "crossover_frequency", "weighted_sensitivity"]

#: the −3 dB level of |T| that defines the bandwidth (feedtune's ``bandwidth``)
HALF_POWER = 1.0 / math.sqrt(2.0)
#: a dip of |T| (or |L|) counts as the crossing only below the level by more than this [1,
#: relative]: Clarabel's feasibility tolerance is 1e-8 on constraints of order 1
DIP_TOL = 1e-6
#: a step of the phase of 1 + L between neighbouring measured points larger than this
#: [rad] is not resolved by the data: the winding count there could be off by a turn
MAX_PHASE_STEP = math.pi / 3
#: the loop gain |L| where the extension below the band ends must be at least this [1],
#: so that 1 + L there is within 30° of L's asymptote
LOW_END_GAIN = 2.0
#: decades the plant's integrator asymptote extends the data below the band [count]
LOW_EXTENSION_DECADES = 6
#: and at most this at the highest [1], so that 1 + L stays in the right half-plane beyond
#: the band (its phase within ±30° of 0, returning to 0 as L → 0)
HIGH_END_GAIN = 0.5
#: the plant's phase at the lowest measured frequency must lie within this of its
#: integrators' asymptote −n_Gπ/2 (or −n_Gπ/2 + π for a negative gain) [rad]
ASYMPTOTE_PHASE = math.pi / 4
#: gains are scaled down by this factor, up to INITIAL_RETRIES times, when the initial
#: controller does not meet the bounds or is not certified stable
INITIAL_SHRINK = 0.5
INITIAL_RETRIES = 12


class DataDrivenError(ValueError):
    """The data or the design problem cannot be used; ``pointer`` is the JSON pointer of the
    spec field at fault (``""`` for the spec as a whole)."""

    def __init__(self, pointer: str, message: str):
        self.pointer, self.message = pointer, message
        super().__init__(f"{pointer or '/'}: {message}")


@dataclass(frozen=True)
class FrequencySet:
    """One measured frequency response G(jω) of the plant (command → position).

    Attributes
    ----------
    name : str
        What the set is (a table position, a load).
    omega : ndarray
        ω [rad/s], strictly increasing, > 0.
    response : ndarray of complex
        G(jω) [position unit per command unit].
    """

    name: str
    omega: np.ndarray
    response: np.ndarray


@dataclass(frozen=True)
class ControllerBasis:
    """K(s) = ρᵀφ(s) over a fixed denominator: P (k_p), PI (k_p + k_i/s), PD
    (k_p + k_d s/(τ_f s + 1)) or PID (all three).

    Attributes
    ----------
    law : {"p", "pi", "pd", "pid"}
    filter_time_constant : float or None
        τ_f [s] of the derivative's filter (PD, PID); fixed, so K stays linear in ρ.
    """

    law: Law
    filter_time_constant: float | None = None

    @property
    def names(self) -> tuple[str, ...]:
        """The parameters' names, in ρ's order: ``kp``, ``ki``, ``kd``."""
        return ("kp",) + (("ki",) if "i" in self.law else ()) + (("kd",) if "d" in self.law else ())

    @property
    def integrators(self) -> int:
        """Poles of K at s = 0 [count]."""
        return 1 if "i" in self.law else 0

    def phi(self, omega: np.ndarray) -> np.ndarray:
        """φ(jω) [1, 1/s, s], shape (len(ω), len(names)), complex."""
        s = 1j * np.asarray(omega, dtype=float)
        columns = [np.ones_like(s)]
        if "i" in self.law:
            columns.append(1.0 / s)
        if "d" in self.law:
            columns.append(s / (self.filter_time_constant * s + 1.0))
        return np.column_stack(columns)

    def response(self, rho: np.ndarray, omega: np.ndarray) -> np.ndarray:
        """K(jω) at parameters ``rho`` [command per position unit]."""
        return self.phi(omega) @ np.asarray(rho, dtype=float)


@dataclass(frozen=True)
class SensitivityWeight:
    """The first-order performance weight W(s) = (s/M + ω_B)/(s + ω_B A) of ‖W S‖∞ ≤ 1:
    |S| ≤ A at low frequency, ≤ M at high frequency, |S| ≈ 1 near ω_B (Skogestad &
    Postlethwaite, *Multivariable Feedback Control*, 2nd ed., §2.8.2, the weight w_P).

    Attributes
    ----------
    bandwidth : float
        ω_B [rad/s], the sensitivity's bandwidth the weight asks for.
    peak : float
        M [1], the bound on |S| at high frequency (|W(j∞)| = 1/M).
    low_gain : float
        A [1], the bound on |S| at low frequency (|W(0)| = 1/A); A < 1 < M.
    """

    bandwidth: float
    peak: float
    low_gain: float

    def magnitude(self, omega: np.ndarray) -> np.ndarray:
        """|W(jω)| [1] at ω [rad/s]."""
        s = 1j * np.asarray(omega, dtype=float)
        return np.abs((s / self.peak + self.bandwidth) / (s + self.bandwidth * self.low_gain))


@dataclass(frozen=True)
class SetCertificate:
    """The Nyquist count of one data set's loop (:func:`nyquist_certificate`)."""

    name: str
    band: tuple[float, float]
    phase_change: float | None
    expected_phase_change: float
    unstable_closed_loop_poles: int | None
    stable: bool
    reason: str

    def as_dict(self) -> dict:
        return {"name": self.name, "band": list(self.band),
                "phase_change_rad": self.phase_change,
                "expected_phase_change_rad": self.expected_phase_change,
                "unstable_closed_loop_poles": self.unstable_closed_loop_poles,
                "stable": self.stable, "reason": self.reason}


def nyquist_certificate(data: FrequencySet, controller, plant_integrators: int,
                        controller_integrators: int, unstable_poles: int) -> SetCertificate:
    """Is the closed loop 1/(1 + L), L = G K, stable, judged from G(jω) measured on a band?

    For a loop with n integrators and P open-loop poles in the right half-plane, 1 + L(jω)
    turns by (n + 2P)·π/2 as ω goes from 0⁺ to ∞ exactly when the closed loop has no
    right-half-plane pole; each such pole takes π from the turn (Z = N + P; for a
    polynomial each left-half-plane root adds π/2, each right-half-plane root −π/2, roots
    at 0 nothing). The turn is the measured band's (the unwrapped phase of 1 + L), plus
    the two unmeasured ends, which the data must make unambiguous:

    * below ω_min the plant follows its integrators' asymptote, G ≈ c/(jω)^{n_G} with c
      = G(jω_min)(jω_min)^{n_G}, whose phase must be within 45° of a real number there;
      the controller K is known exactly, so L is extended six decades down with it, to
      where 1 + L is within 30° of L's asymptote −nπ/2 (or −nπ/2 + π; n = 0: L(0) real);
    * above ω_max the loop rolls off: |L(ω_max)| ≤ 0.5, so 1 + L returns to phase 0 from
      within ±30° (assumed: |L| stays below 1 beyond the band);
    * between neighbouring points the phase of 1 + L moves by less than 60°.

    Parameters
    ----------
    data : FrequencySet
        The plant's measured response G(jω) [position per command], ω [rad/s].
    controller : callable
        ω [rad/s] → K(jω) [command per position] (the known controller).
    plant_integrators, controller_integrators : int
        Poles of G and of K at s = 0 [count].
    unstable_poles : int
        Poles of the plant in the open right half-plane [count] (the controller's are
        stable by construction).

    Returns
    -------
    SetCertificate
        ``stable`` true only when every condition above holds and the count is (n + 2P)·π/2.
    """
    band = (float(data.omega[0]), float(data.omega[-1]))
    n, p = plant_integrators + controller_integrators, unstable_poles
    expected = (n + 2 * p) * math.pi / 2

    def fail(reason, change=None, poles=None):
        return SetCertificate(data.name, band, change, expected, poles, False, reason)

    c = data.response[0] * (1j * band[0]) ** plant_integrators  # G ≈ c/(jω)^{n_G} below
    if abs(math.sin(np.angle(c))) > math.sin(ASYMPTOTE_PHASE):
        return fail(f"the plant's phase at the lowest measured frequency {band[0]:.6g} rad/s "
                    f"is {math.degrees(np.angle(data.response[0])):.0f}°, more than "
                    f"{math.degrees(ASYMPTOTE_PHASE):.0f}° from the asymptote of "
                    f"{plant_integrators} integrator(s): the data must start lower")
    low = band[0] * np.logspace(-LOW_EXTENSION_DECADES, 0, 24 * LOW_EXTENSION_DECADES,
                                endpoint=False)
    omega = np.concatenate([low, data.omega])
    plant = np.concatenate([c / (1j * low) ** plant_integrators, data.response])
    loop = plant * controller(omega)
    if not np.all(np.isfinite(loop)):
        return fail("L is not finite at every measured frequency")
    if abs(loop[-1]) > HIGH_END_GAIN:
        return fail(f"|L| = {abs(loop[-1]):.3g} at the highest measured frequency "
                    f"{band[1]:.6g} rad/s; the data must reach where |L| ≤ {HIGH_END_GAIN}")
    x = 1.0 + loop
    if np.any(np.abs(x) == 0.0):
        return fail("1 + L = 0 at a measured frequency (a closed-loop pole on the jω axis)")
    phase = np.unwrap(np.angle(x))
    steps = np.abs(np.diff(phase))
    if steps.size and steps.max() > MAX_PHASE_STEP:
        i = int(steps.argmax())
        return fail(f"the phase of 1 + L moves by {math.degrees(steps[i]):.0f}° between "
                    f"{omega[i]:.6g} and {omega[i + 1]:.6g} rad/s: the data are too "
                    "sparse there to count the encirclements")
    sign = 1.0 if (loop[0] * (1j * omega[0]) ** n).real >= 0 else -1.0
    start = -n * math.pi / 2 + (0.0 if sign > 0 else math.pi)
    if n > 0 and abs(loop[0]) < LOW_END_GAIN:
        return fail(f"|L| = {abs(loop[0]):.3g} at {omega[0]:.3g} rad/s, six decades below the "
                    "band: the loop's low-frequency gain is too small to count from")
    if n == 0:
        start = 0.0 if x[0].real > 0 else math.pi
    # the branch of the phase nearest the low end's asymptote (|difference| < π/2 there)
    phase = phase + 2 * math.pi * round((start - phase[0]) / (2 * math.pi))
    end = 2 * math.pi * round(phase[-1] / (2 * math.pi))  # 1 + L → 1 beyond the band
    change = float(end - start)
    poles = int(round((expected - change) / math.pi))
    if poles != 0:
        return fail(f"1 + L turns by {change / math.pi:.3g}π against {expected / math.pi:.3g}π "
                    f"for {n} integrator(s) and {p} unstable pole(s): {poles} closed-loop "
                    "pole(s) in the right half-plane", change, poles)
    return SetCertificate(data.name, band, change, expected, 0, True,
                          f"Nyquist: 1 + L turns by {change / math.pi:.3g}π over the measured "
                          f"{band[0]:.6g}–{band[1]:.6g} rad/s and its ends (the plant's "
                          f"{plant_integrators} integrator(s) below, |L| ≤ {HIGH_END_GAIN} "
                          f"above), as {n} integrator(s) and {p} unstable pole(s) require: "
                          "no closed-loop pole in the right half-plane")


def _first_crossing_below(omega: np.ndarray, value: np.ndarray, level: float) -> float | None:
    """The lowest ω [rad/s] where ``value`` falls below ``level`` (log-log interpolation
    between the neighbouring measured points); the first point if it starts below; None if
    it never does on the band. A point counts as below only under level·(1 − DIP_TOL): a
    design that widens the bandwidth holds a dip exactly at the level, which the solver's
    tolerance may leave a hair under (as feedtune's bandwidth on a model, README)."""
    below = np.flatnonzero(value < level * (1 - DIP_TOL))
    if below.size == 0:
        return None
    i = int(below[0])
    if i == 0:
        return float(omega[0])
    w0, w1, v0, v1 = np.log(omega[i - 1]), np.log(omega[i]), np.log(value[i - 1]), np.log(value[i])
    return float(np.exp(w0 + (math.log(level) - v0) * (w1 - w0) / (v1 - v0)))


def interpolated_peak(omega: np.ndarray, value: np.ndarray) -> float:
    """The largest value of ``value`` between and at the measured ω: at every interior
    local maximum, the vertex of the parabola in ln ω through it and its two neighbours
    (feedtune's refinement of a peak between grid points, on data); the ends as measured.

    Parameters
    ----------
    omega : ndarray
        ω [rad/s], increasing.
    value : ndarray
        |T| or |S| there [1].

    Returns
    -------
    float
        The peak [1], at least ``value.max()``.
    """
    x = np.log(omega)
    peak = float(value.max())
    y0, y1, y2 = value[:-2], value[1:-1], value[2:]
    is_max = (y1 >= y0) & (y1 >= y2)
    if not is_max.any():
        return peak
    h0, h1 = (x[1:-1] - x[:-2])[is_max], (x[2:] - x[1:-1])[is_max]
    y0, y1, y2 = y0[is_max], y1[is_max], y2[is_max]
    d1, d2 = (y1 - y0) / h0, (y2 - y1) / h1
    alpha = (d2 - d1) / (h0 + h1)   # y = y1 + β t + α t², t = ln ω − ln ω_i
    beta = d1 + alpha * h0
    with np.errstate(divide="ignore", invalid="ignore"):
        vertex = np.where(alpha < 0, y1 - beta**2 / (4 * alpha), y1)
    return max(peak, float(np.max(vertex)))


def set_metrics(data: FrequencySet, loop: np.ndarray,
                weight: SensitivityWeight | None = None) -> dict[str, float | None]:
    """The frequency metrics of one data set's loop at its measured frequencies.

    Parameters
    ----------
    data : FrequencySet
    loop : ndarray of complex
        L = G K at ``data.omega`` [1].
    weight : SensitivityWeight, optional
        W of ``weighted_sensitivity`` = max |W S| [1] (and ``_measured``), given one.

    Returns
    -------
    dict
        ``m_peak`` = max |T| [1] (T(0) = 1 for a loop with an integrator) and
        ``sensitivity_peak`` = max |S| [1], each with the parabola between measured points
        (:func:`interpolated_peak`), and as measured (``m_peak_measured``,
        ``sensitivity_peak_measured``); ``bandwidth`` [rad/s] where |T| first falls below 1/√2 and
        ``crossover_frequency`` [rad/s] where |L| first falls below 1 (log-log interpolation
        between measured points; None when it does not within the band), ``phase_margin``
        [deg]: 180° + the phase of L at the crossover (interpolated linearly in ln ω).
    """
    x = 1.0 + loop
    t = np.abs(loop / x)
    crossover = _first_crossing_below(data.omega, np.abs(loop), 1.0)
    margin = None
    if crossover is not None:
        phase = np.unwrap(np.angle(loop))
        at = float(np.interp(math.log(crossover), np.log(data.omega), phase))
        margin = math.degrees(at) + 180.0
        margin -= 360.0 * math.floor((margin + 180.0) / 360.0)  # within (−180°, 180°]
    sensitivity = np.abs(1.0 / x)
    out = {"m_peak": interpolated_peak(data.omega, t),
           "sensitivity_peak": interpolated_peak(data.omega, sensitivity),
           "m_peak_measured": float(t.max()),
           "sensitivity_peak_measured": float(sensitivity.max()),
           "bandwidth": _first_crossing_below(data.omega, t, HALF_POWER),
           "crossover_frequency": crossover, "phase_margin": margin}
    if weight is not None:
        weighted = weight.magnitude(data.omega) * sensitivity
        out["weighted_sensitivity"] = interpolated_peak(data.omega, weighted)
        out["weighted_sensitivity_measured"] = float(weighted.max())
    return out


#: the peaks (worst: the largest over the sets); every other metric's worst is its least
PEAKS = ("m_peak", "sensitivity_peak", "weighted_sensitivity")


def worst_case(per_set: Sequence[Mapping[str, float | None]]) -> dict[str, float | None]:
    """The worst value of each metric over the sets: the largest peak, the smallest
    bandwidth, crossover and margin (None when any set has none)."""
    out = {}
    for key in per_set[0]:
        pick = max if key.removesuffix("_measured") in PEAKS else min
        values = [m[key] for m in per_set]
        out[key] = None if any(v is None for v in values) else float(pick(values))
    return out


@dataclass
class Design:
    """What :func:`design` found.

    Attributes
    ----------
    values : dict
        Parameter name → value [its unit] (``kp``, ``ki``, ``kd``).
    status : {"optimal", "iteration_limit", "infeasible", "error"}
    message : str
    iterations : int
        Linearisations (each a search over ω_b) [count].
    solves : int
        SOCPs solved [count].
    per_set : list of dict
        :func:`set_metrics` of every set at ``values``.
    metrics : dict
        :func:`worst_case` of ``per_set``.
    certificates : list of SetCertificate
    history : list of float
        The objective [rad/s] after each linearisation.
    solve_time : float
        Wall time of the SOCPs [s].
    build_time : float
        Wall time to build the cvxpy problem [s].
    """

    values: dict[str, float]
    status: str
    message: str
    iterations: int
    solves: int
    per_set: list[dict]
    metrics: dict
    certificates: list[SetCertificate]
    history: list[float] = field(default_factory=list)
    solve_time: float = 0.0
    build_time: float = 0.0

    @property
    def stable(self) -> bool:
        return bool(self.certificates) and all(c.stable for c in self.certificates)


class _Loops:
    """L_i(ρ) = a_iᵀρ at every measured point of every set, stacked."""

    def __init__(self, sets: Sequence[FrequencySet], basis: ControllerBasis):
        self.sets, self.basis = list(sets), basis
        parts = [s.response[:, None] * basis.phi(s.omega) for s in self.sets]
        self.a = np.vstack(parts)
        self.omega = np.concatenate([s.omega for s in self.sets])
        self.slices = []
        start = 0
        for part in parts:
            self.slices.append(slice(start, start + len(part)))
            start += len(part)

    def loop(self, rho: np.ndarray) -> np.ndarray:
        return self.a @ rho

    def evaluate(self, rho: np.ndarray, integrators: int, unstable_poles: int,
                 weight: SensitivityWeight | None = None):
        """(per-set metrics, certificates) at ``rho``; ``integrators``: the plant's."""
        loop = self.loop(rho)
        per_set, certificates = [], []

        def controller(omega):
            return self.basis.response(rho, omega)

        for data, part in zip(self.sets, self.slices):
            per_set.append(set_metrics(data, loop[part], weight))
            certificates.append(nyquist_certificate(data, controller, integrators,
                                                    self.basis.integrators, unstable_poles))
        return per_set, certificates


def _meets(metrics: Mapping, bounds: Mapping[str, float], slack: float = 0.0,
           suffix: str = "") -> bool:
    """The peaks (``suffix`` ``_measured``: at the measured points only) within ``bounds``
    (peak name → its upper bound [1])."""
    return all(metrics[name + suffix] <= bound * (1 + slack) for name, bound in bounds.items())


#: times the points are held to tighter bounds when a peak between them is over its bound
GRID_REFINEMENTS = 3
#: and how much tighter than the ratio that was over [1]: the parabola through three points
#: misses the true peak by a third-order term in their spacing; on Bhatia's hydraulic drive
#: sampled 100 points a decade it under-estimated a dense evaluation's M_peak by 1.1e-4
GRID_MARGIN = 3e-4
#: relative tolerance on the bounds when the design checks the solver's answer: Clarabel's
#: feasibility tolerance (1e-8) on constraints scaled to O(1)
BOUND_SLACK = 1e-6
#: Clarabel's output on stderr (debugging)
VERBOSE = False
#: Clarabel's tolerances: 1e-7 rather than its 1e-8 (two fewer interior-point iterations of
#: about twenty); every answer is checked against the true bounds with BOUND_SLACK
CLARABEL = {"tol_gap_abs": 1e-7, "tol_gap_rel": 1e-7, "tol_feas": 1e-7}
#: the working set's sizes [points]: the SOCP is built once per size (padded by repeating
#: a point), the smallest that holds the chosen points is solved (_Exchange)
WORKING_SIZES = (32, 64, 128, 256, 512, 1024)
#: a point joins the first working set when it is this near a bound at ρ_c [1; 1 = on it]
TIGHT = 0.9
#: violated points that join the working set a round, at most, the most violated first
ADDED = 16
#: the largest slack the SOCP may report [1]: bounds it where no point is active
SLACK_CAP = 1e3
#: next points above ω_b, one per set, whose slack the last solve of a linearisation widens
NEXT = 16
#: a point's linearised constraint violated by more than this [1, relative to |X_c|]
#: joins the working set (Clarabel's feasibility tolerance is 1e-8)
EXCHANGE_TOL = 1e-7


class _Socp:
    """The SOCP of one linearisation on ``rows`` measured points, built once with cvxpy
    Parameters (DPP: a new ρ_c, ω_b or set of points only updates numbers).

    ``bounds``: peak name (``m_peak``, ``sensitivity_peak``, ``weighted_sensitivity``) → its
    upper bound [1]. For the objective ``weighted_sensitivity`` the slack s is 1/γ of
    |W S| ≤ γ: with X = 1 + L, |W|/|X| ≤ 1/s ⇐ Re{X_c* X}/|X_c| ≥ |W| s, linear in (ρ, s),
    written relative to |X_c| (Re{X_c* X}/|X_c|² ≥ (|W|/|X_c|) s) so every row is O(1)."""

    def __init__(self, rows: int, p: int, z_box: tuple[np.ndarray, np.ndarray],
                 bounds: Mapping[str, float], objective: Objective):
        import cvxpy as cp

        self.cp = cp
        self.objective = objective
        self.z = cp.Variable(p)
        self.s = cp.Variable()
        self.ar = cp.Parameter((rows, p))     # Re a, Im a: L = a z
        self.ai = cp.Parameter((rows, p))
        self.x_dir = cp.Parameter((rows, p))  # Re{X_c* a}/|X_c|
        self.x_0 = cp.Parameter(rows)         # Re{X_c}/|X_c|
        z, s = self.z, self.s
        re_x = self.x_0 + self.x_dir @ z
        constraints = [z >= z_box[0], z <= z_box[1], re_x >= 0, s <= SLACK_CAP]
        if "m_peak" in bounds:
            constraints.append(cp.SOC(bounds["m_peak"] * re_x,
                                      cp.vstack([self.ar @ z, self.ai @ z]), axis=0))
        if "sensitivity_peak" in bounds:
            constraints.append(bounds["sensitivity_peak"] * re_x >= 1.0)
        self.weighted = "weighted_sensitivity" in bounds or objective == "weighted_sensitivity"
        if self.weighted:
            self.xr_dir = cp.Parameter((rows, p))         # Re{X_c* a}/|X_c|²
            self.xr_0 = cp.Parameter(rows)                # Re{X_c}/|X_c|²
            self.w_rel = cp.Parameter(rows, nonneg=True)  # |W|/|X_c| = |W S_c|
            re_rel = self.xr_0 + self.xr_dir @ z
            if "weighted_sensitivity" in bounds:
                constraints.append(bounds["weighted_sensitivity"] * re_rel >= self.w_rel)
        if objective == "weighted_sensitivity":
            constraints += [re_rel >= cp.multiply(self.w_rel, s), s >= 0]
            self.problem = cp.Problem(cp.Maximize(s), constraints)
            return
        self.l_dir = cp.Parameter((rows, p))  # Re{L_c* a}/|L_c|, 0 above ω_b
        self.weight = cp.Parameter(rows, nonneg=True)  # the slack's scale |L_c|, 0 above ω_b
        self.active = cp.Parameter(rows, nonneg=True)  # 1 where ω ≤ ω_b, else 0
        self.ar_active = cp.Parameter((rows, p))       # Re a, Im a there, else 0
        self.ai_active = cp.Parameter((rows, p))
        # the next measured point of each set above ω_b, whose slack t the last solve of a
        # linearisation widens (NEXT rows; 0 where unused), and which objective is maximised
        self.t = cp.Variable()
        self.next_dir = cp.Parameter((NEXT, p))
        self.next_weight = cp.Parameter(NEXT, nonneg=True)
        self.next_on = cp.Parameter(NEXT, nonneg=True)
        self.next_ar = cp.Parameter((NEXT, p))
        self.next_ai = cp.Parameter((NEXT, p))
        self.s_floor = cp.Parameter()                  # −SLACK_CAP, or 0 when t is maximised
        self.goal = cp.Parameter(2, nonneg=True)       # (1, 0): maximise s; (0, 1): t
        t = self.t
        constraints += [t <= SLACK_CAP, s >= self.s_floor]
        # the objective's condition; above ω_b every coefficient is 0 (0 ≤ 0)
        lower = self.l_dir @ z - cp.multiply(self.weight, s)
        upper = self.next_dir @ z - cp.multiply(self.next_weight, t)
        if objective == "bandwidth":
            constraints.append(cp.SOC(math.sqrt(2.0) * lower, cp.vstack([
                self.active + self.ar_active @ z, self.ai_active @ z]), axis=0))
            constraints.append(cp.SOC(math.sqrt(2.0) * upper, cp.vstack([
                self.next_on + self.next_ar @ z, self.next_ai @ z]), axis=0))
        else:
            constraints += [lower >= self.active, upper >= self.next_on]
        self.problem = cp.Problem(cp.Maximize(self.goal[0] * s + self.goal[1] * t), constraints)

    def _set_widening(self, active: np.ndarray, a: np.ndarray, l_c: np.ndarray,
                      following: tuple[np.ndarray, np.ndarray] | None) -> None:
        """The bandwidth's (crossover's) parameters: its condition where ``active``, and
        the next points' slack when ``following`` is given."""
        rows = np.zeros((NEXT, a.shape[1]), dtype=complex), np.ones(NEXT, dtype=complex)
        on_next = np.zeros(NEXT)
        if following is not None:
            n = len(following[0])
            rows[0][:n], rows[1][:n] = following
            on_next[:n] = 1.0
        a_n, l_n = rows
        self.next_dir.value = (np.conj(l_n)[:, None] * a_n).real / np.abs(l_n)[:, None] * on_next[:, None]
        self.next_weight.value = np.abs(l_n) * on_next
        self.next_on.value = on_next
        self.next_ar.value, self.next_ai.value = a_n.real, a_n.imag
        self.s_floor.value = 0.0 if following is not None else -SLACK_CAP
        self.goal.value = np.array([0.0, 1.0] if following is not None else [1.0, 0.0])
        on = active.astype(float)
        self.l_dir.value = (np.conj(l_c)[:, None] * a).real / np.abs(l_c)[:, None] * on[:, None]
        self.weight.value = np.abs(l_c) * on
        self.active.value = on
        self.ar_active.value, self.ai_active.value = a.real * on[:, None], a.imag * on[:, None]

    def solve(self, a: np.ndarray, x_c: np.ndarray, l_c: np.ndarray, active: np.ndarray,
              following: tuple[np.ndarray, np.ndarray] | None = None,
              w: np.ndarray | None = None) -> tuple[float | None, np.ndarray | None]:
        """(largest smallest slack s, z) on the points of ``a`` (rows: L = a z), linearised at
        X_c = 1 + L_c, with the objective's condition where ``active``; with ``following``
        (a, L_c of the next points above ω_b) the z that keeps every active slack ≥ 0 and
        widens the next points' smallest slack most; ``w``: |W| at the points [1] (the
        weighted sensitivity's). (None, None) when the solver fails."""
        if self.objective != "weighted_sensitivity":
            self._set_widening(active, a, l_c, following)
        self.ar.value, self.ai.value = a.real, a.imag
        x_dir = (np.conj(x_c)[:, None] * a).real
        size = np.abs(x_c)
        self.x_dir.value = x_dir / size[:, None]
        self.x_0.value = x_c.real / size
        if self.weighted:
            self.xr_dir.value = x_dir / size[:, None] ** 2
            self.xr_0.value = x_c.real / size**2
            self.w_rel.value = w / size
        try:
            with warnings.catch_warnings():  # "optimal_inaccurate": the answer is checked below
                warnings.simplefilter("ignore", UserWarning)
                self.problem.solve(solver=self.cp.CLARABEL, verbose=VERBOSE, **CLARABEL)
        except self.cp.error.SolverError:
            return None, None
        if self.problem.status not in ("optimal", "optimal_inaccurate") or self.z.value is None:
            return None, None
        return float(self.s.value), np.asarray(self.z.value, dtype=float)


class _Exchange:
    """Every measured point's constraints, solved on a working set of the tightest ones
    (the exchange method): the SOCP holds the points within ``TIGHT`` of a bound at ρ_c
    (at least the 32 tightest); after each solve every point's linearised constraints are
    checked in numpy, the violated ones join the set and it is solved again, so the answer
    is that of the SOCP on all points. Most points are far from every bound (|T| ≪ M above
    the resonances, |L| ≫ 1 far below ω_b), and an SOCP's cost grows with its points
    (Clarabel, 3 sets × 500 points: ≈ 7 ms of CPU on 60 points, 27 ms on 240, 137 ms on all
    1 500), so the set is kept small: one SOCP per size of ``WORKING_SIZES`` (and one of
    all points), the chosen points padded to the size by repeating one of them."""

    def __init__(self, a: np.ndarray, omega: np.ndarray, z_box, bounds: Mapping[str, float],
                 objective: Objective, w: np.ndarray | None = None):
        self.a, self.omega, self.w = a, omega, w
        self.bounds, self.objective = dict(bounds), objective
        self.sizes = [n for n in WORKING_SIZES if n < len(a)] + [len(a)]
        self.socps: dict[int, _Socp] = {}
        self.p, self.z_box = a.shape[1], z_box
        self.solves = 0
        self.build_time = 0.0  # wall time building the SOCPs [s]

    def _socp(self, rows: int) -> _Socp:
        if rows not in self.socps:
            tick = time.perf_counter()
            self.socps[rows] = _Socp(rows, self.p, self.z_box, self.bounds, self.objective)
            self.build_time += time.perf_counter() - tick
        return self.socps[rows]

    def linearise(self, z_c: np.ndarray) -> None:
        self.l_c = self.a @ z_c
        self.x_c = 1.0 + self.l_c

    def _violation(self, z: np.ndarray, s: float, active: np.ndarray) -> np.ndarray:
        """Each point's largest violation of its linearised constraints at (z, s) [1,
        relative to |X_c| or |L_c|]."""
        l = self.a @ z
        x_c, l_c = self.x_c, self.l_c
        size = np.abs(x_c)
        re_x = (np.conj(x_c) * (1.0 + l)).real / size
        worst = np.maximum(-re_x, 0.0)
        bounds = self.bounds
        if "m_peak" in bounds:
            worst = np.maximum(worst, (np.abs(l) - bounds["m_peak"] * re_x) / size)
        if "sensitivity_peak" in bounds:
            worst = np.maximum(worst, (1.0 - bounds["sensitivity_peak"] * re_x) / size)
        if "weighted_sensitivity" in bounds:
            worst = np.maximum(worst, (self.w / bounds["weighted_sensitivity"] - re_x) / size)
        if self.objective == "weighted_sensitivity":
            return np.maximum(worst, (self.w * s - re_x) / size)
        lower = (np.conj(l_c) * l).real / np.abs(l_c) - np.abs(l_c) * s
        need = np.abs(1.0 + l) / math.sqrt(2.0) if self.objective == "bandwidth" else 1.0
        worst = np.maximum(worst, np.where(active, (need - lower) / np.abs(l_c), 0.0))
        return worst

    def _tightness(self, active: np.ndarray) -> np.ndarray:
        """How near each point is to a bound at ρ_c [1; 1 = on it]."""
        t = np.abs(self.l_c / self.x_c)
        score = np.zeros(len(t))
        bounds = self.bounds
        if "m_peak" in bounds:
            score = np.maximum(score, t / bounds["m_peak"])
        if "sensitivity_peak" in bounds:
            score = np.maximum(score, 1.0 / (np.abs(self.x_c) * bounds["sensitivity_peak"]))
        if self.w is not None:
            weighted = self.w / np.abs(self.x_c)  # |W S_c|
            if "weighted_sensitivity" in bounds:
                score = np.maximum(score, weighted / bounds["weighted_sensitivity"])
            if self.objective == "weighted_sensitivity":
                return np.maximum(score, weighted / weighted.max())
        level = HALF_POWER if self.objective == "bandwidth" else 1.0
        near = level / (t if self.objective == "bandwidth" else np.abs(self.l_c))
        return np.maximum(score, np.where(active, near, 0.0))

    def solve(self, active: np.ndarray, following: np.ndarray | None = None
              ) -> tuple[float | None, np.ndarray | None]:
        """As :meth:`_Socp.solve`, every point's constraints held; ``following``: the
        indices of the next points above ω_b, whose slack is then widened."""
        nxt = None if following is None else (self.a[following], self.l_c[following])
        w = self.w if self.w is not None else np.zeros(len(self.a))
        tightness = self._tightness(active)
        order = np.argsort(-tightness)
        chosen = order[:max(int(np.count_nonzero(tightness >= TIGHT)), self.sizes[0])]
        while True:
            rows = next(n for n in self.sizes if n >= len(chosen))
            index = np.concatenate([chosen, np.full(rows - len(chosen), chosen[0])])
            self.solves += 1
            s, z = self._socp(rows).solve(self.a[index], self.x_c[index], self.l_c[index],
                                          active[index], nxt, w[index])
            if z is None or rows == len(self.a):
                return s, z
            violation = self._violation(z, s, active)
            violation[chosen] = 0.0
            worst = np.flatnonzero(violation > EXCHANGE_TOL)
            if worst.size == 0:
                return s, z
            # the most violated join, at most ADDED a round (many violated points are
            # neighbours, held by the same few)
            worst = worst[np.argsort(-violation[worst])[:ADDED]]
            chosen = np.concatenate([chosen, worst])


def _bisect(feasible, low: int, high: int, z_low):
    """The largest index in (low, high) that ``feasible`` accepts, by bisection, with its
    solution; (low, z_low) when none is (``high`` is known infeasible, ``low`` feasible)."""
    while high - low > 1:
        mid = (low + high) // 2
        ok, z = feasible(mid)
        if ok:
            low, z_low = mid, z
        else:
            high = mid
    return low, z_low


def design(sets: Sequence[FrequencySet], basis: ControllerBasis,
           box: Mapping[str, tuple[float, float]], initial: Mapping[str, float], *,
           m_peak: float | None = None, sensitivity_peak: float | None = None,
           weighted_sensitivity: float | None = None, weight: SensitivityWeight | None = None,
           objective: Objective = "bandwidth", integrators: int = 0, unstable_poles: int = 0,
           max_iter: int = 50, tol: float = 1e-4, time_limit: float | None = None) -> Design:
    """The controller of ``basis`` with the widest bandwidth (or crossover), or the least
    weighted sensitivity, whose bounds hold at every measured frequency of every set, stable
    by :func:`nyquist_certificate` on each.

    Parameters
    ----------
    sets : sequence of FrequencySet
        The measured plant responses (position per command).
    basis : ControllerBasis
    box : mapping
        Parameter name → (min, max) [its unit]; min == max fixes it.
    initial : mapping
        Parameter name → the first controller ρ_c [its unit]; it should stabilise every
        set's loop. If it does not, or breaks a bound, every gain is halved (up to 12 times)
        until it does.
    m_peak, sensitivity_peak, weighted_sensitivity : float, optional
        Bounds on max |T|, max |S| and max |W S| [1] at every measured frequency of every set.
    weight : SensitivityWeight, optional
        W of ``weighted_sensitivity`` (needed for its bound or objective).
    objective : {"bandwidth", "crossover_frequency", "weighted_sensitivity"}
        Maximised: the lowest −3 dB point of |T| over the sets, or the lowest |L| = 1 point;
        or minimised: the largest max |W S| over the sets (each linearisation maximises s
        with Re{X_c* X}/|X_c| ≥ |W| s at every point, so max |W S| ≤ 1/s).
    integrators : int
        Poles of the *plant* at s = 0 [count] (the controller's are added).
    unstable_poles : int
        Poles of the plant in the open right half-plane [count].
    max_iter : int
        Linearisations at most [count].
    tol : float
        Stop when the objective no longer improves (the bandwidth's grid index, or the
        weighted sensitivity by more than ``tol`` relative) and ρ moves by less than this,
        relative [1].
    time_limit : float, optional
        Wall-time limit [s]: the design so far is returned (status ``time_limit``).

    Returns
    -------
    Design
        Never raises for a problem the solver meets: its status says what happened.

    Raises
    ------
    DataDrivenError
        No initial controller found that is stable on every set and meets the bounds.
    ValueError
        A weighted sensitivity asked for without its ``weight``.
    """
    bounds = {name: bound for name, bound in (("m_peak", m_peak),
                                              ("sensitivity_peak", sensitivity_peak),
                                              ("weighted_sensitivity", weighted_sensitivity))
              if bound is not None}
    weighted = objective == "weighted_sensitivity" or "weighted_sensitivity" in bounds
    if weighted and weight is None:
        raise ValueError("a weighted sensitivity needs its weight W")
    names = basis.names
    lo = np.array([box[n][0] for n in names], dtype=float)
    hi = np.array([box[n][1] for n in names], dtype=float)
    rho = np.clip(np.array([initial[n] for n in names], dtype=float), lo, hi)
    loops = _Loops(sets, basis)
    w = weight.magnitude(loops.omega) if weighted else None
    started = time.perf_counter()
    candidates = np.unique(loops.omega)
    everywhere = np.ones(len(loops.omega), dtype=bool)
    scale, socps = None, {}
    history, iterations, solves, solve_time = [], 0, 0, 0.0
    notes: list[str] = []  # what happened besides the last round's ending
    grid = dict(bounds)  # the bounds the SOCPs hold at the points

    def evaluate(at):
        return loops.evaluate(at, integrators, unstable_poles, weight if weighted else None)

    def reach(metrics) -> int:
        """Index in ``candidates`` of the last frequency below the objective's crossing."""
        value = metrics[objective]
        if value is None:
            return len(candidates) - 1
        return max(int(np.searchsorted(candidates, value, side="right")) - 1, -1)

    for refinement in range(GRID_REFINEMENTS + 1):
        # a stabilising controller within the bounds at the points: where the method starts
        # (a refinement goes on from the last iterate, just over its tighter bounds)
        for _ in range(INITIAL_RETRIES + 1):
            per_set, certificates = evaluate(rho)
            if refinement > 0 or (all(c.stable for c in certificates) and _meets(
                    worst_case(per_set), grid, suffix="_measured")):
                break
            rho = np.clip(rho * INITIAL_SHRINK, lo, hi)
        else:
            reasons = "; ".join(f"{c.name}: {c.reason}" for c in certificates if not c.stable)
            raise DataDrivenError("/tunables", "no initial controller that is stable on every "
                                  "data set and meets the bounds: the tunables' initial values, "
                                  f"halved up to {INITIAL_RETRIES} times, were not "
                                  f"({reasons or 'bounds'}); give initial values of a "
                                  "controller known to work")
        if scale is None:
            scale = np.where(rho > 0, rho, np.sqrt(lo * hi))
        key = tuple(sorted(grid.items()))
        if key not in socps:
            socps[key] = _Exchange(loops.a * scale, loops.omega, (lo / scale, hi / scale),
                                   grid, objective, w)
        socp = socps[key]
        tightened = refinement > 0
        metrics = worst_case(per_set)
        status, message = ITERATION_LIMIT, ""
        while iterations < max_iter:
            iterations += 1
            socp.linearise(rho / scale)
            tick = time.perf_counter()
            if objective == "weighted_sensitivity":
                s_new, best_z = socp.solve(everywhere)
                if best_z is not None and not s_new > 0:
                    best_z = None
            else:
                k = reach(metrics)
                best_z, failed = _widen(socp, loops, candidates, k, tightened)
                tightened = False
                if failed:
                    status, message = INFEASIBLE, ("no controller of this structure meets "
                                                      "the bounds at every measured point")
                    break
            solve_time += time.perf_counter() - tick
            if best_z is None:
                status, message = OPTIMAL, (f"no controller improves the {objective} beyond "
                                              "the current one at this linearisation")
                break
            new_rho = best_z * scale
            new_per_set, new_certificates = evaluate(new_rho)
            new_metrics = worst_case(new_per_set)
            if not (all(c.stable for c in new_certificates)
                    and _meets(new_metrics, grid, BOUND_SLACK, "_measured")):
                status, message = OPTIMAL, ("the next iterate left the certified set (solver "
                                              "tolerance); the last certified one is kept")
                break
            moved = float(np.linalg.norm(new_rho - rho) / max(np.linalg.norm(rho), 1e-300))
            if objective == "weighted_sensitivity":
                improved = (new_metrics[objective]
                            < metrics[objective] * (1 - tol))
            else:
                improved = reach(new_metrics) > k
            rho, per_set, certificates, metrics = new_rho, new_per_set, new_certificates, new_metrics
            history.append(metrics[objective] if metrics[objective] is not None else math.inf)
            if not improved and moved < tol:
                status, message = OPTIMAL, (f"converged: the {objective} stopped improving and "
                                              f"ρ moved by {moved:.2g} (< tol {tol:g}) relative")
                break
            if time_limit is not None and time.perf_counter() - started > time_limit:
                status, message = TIME_LIMIT, f"time limit {time_limit:g} s reached"
                break
        else:
            message = f"{max_iter} linearisations without converging; the last iterate is kept"
        solves = sum(x.solves for x in socps.values())
        if status != OPTIMAL or _meets(metrics, bounds, BOUND_SLACK):
            break
        # a peak between the measured points is over its bound: hold the points tighter
        for name, bound in bounds.items():
            if metrics[name] > bound * (1 + BOUND_SLACK):
                grid[name] = grid[name] * bound / metrics[name] * (1 - GRID_MARGIN)
        held = ", ".join(f"{LABELS[name]} {value:.6g}" for name, value in grid.items())
        notes.append("a peak between measured points was over its bound: the points held to "
                     + held)
    build_time = sum(x.build_time for x in socps.values())  # inside the solves' time
    solve_time -= build_time
    if not _meets(metrics, bounds, BOUND_SLACK) and status == OPTIMAL:
        status = INFEASIBLE
        notes.append("a peak between the measured points is still over its bound")
    return Design(values=dict(zip(names, (float(v) for v in rho))), status=status,
                  message="; ".join([message, *notes]), iterations=iterations, solves=solves, per_set=per_set,
                  metrics=metrics, certificates=certificates, history=history,
                  solve_time=solve_time, build_time=build_time)


#: the peaks' names in messages
LABELS = {"m_peak": "M_peak", "sensitivity_peak": "M_s", "weighted_sensitivity": "‖W S‖∞"}


def _widen(socp: _Exchange, loops: _Loops, candidates: np.ndarray, k: int, tightened: bool
           ) -> tuple[np.ndarray | None, bool]:
    """One linearisation of the bandwidth (crossover) design: the largest feasible prefix
    of the measured frequencies, from the current ``k`` (an index in ``candidates``),
    searched upwards by doubling, then bisection, and the next points' slack widened.

    Returns
    -------
    (z, failed)
        z: the new scaled parameters, None when nothing widens the objective; ``failed``:
        after a refinement (``tightened``) no prefix at all is feasible.
    """
    def prefix(index):
        """The points at or below candidate ``index`` (none for index < 0)."""
        return (loops.omega <= candidates[index] if index >= 0
                else np.zeros(len(loops.omega), dtype=bool))

    def feasible(index):
        s, z_new = socp.solve(prefix(index))
        return (s is not None and s >= -1e-9), z_new

    # the current point is feasible at k (unless a refinement tightened the bounds):
    # search upwards, doubling, then bisect
    best_k, best_z = k, None
    ok = True  # ρ_c itself holds at k (s = 0), unless the bounds were just tightened
    if tightened:
        ok, best_z = feasible(k)
    if not ok:  # only after a refinement: search downwards
        best_k, best_z = _bisect(feasible, -2, k, None)
        if best_z is None:
            return None, True
    step, upper = 1, None
    while best_k + step < len(candidates):
        ok, z_try = feasible(best_k + step)
        if not ok:
            upper = best_k + step
            break
        best_k, best_z, step = best_k + step, z_try, step * 2
    if upper is not None:
        best_k, best_z = _bisect(feasible, best_k, upper, best_z)
    if best_k + 1 < len(candidates):  # widen towards the next point of each set
        following = np.array([sl.start + int(np.searchsorted(
            loops.omega[sl], candidates[best_k], side="right"))
            for sl in loops.slices])
        following = following[following < [sl.stop for sl in loops.slices]][:NEXT]
        s_final, z_final = socp.solve(prefix(best_k), following)
        if z_final is not None and s_final >= -1e-9:
            best_z = z_final
    return best_z, False
