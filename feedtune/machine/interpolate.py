"""The interpolator: a :class:`Path` → per-axis position references sampled every T.

``interpolate(path: Path, *, period: float, max_acceleration: float | None = None,
corner_tolerance: float | None = None, time_constant: float | None = None,
feed_override: float = 1.0) -> Reference``

Feed profile
------------
Each block (segment) is cut at its programmed feed F_k [m/s]. Without
``max_acceleration`` the feed is exactly F_k over the whole block and jumps at block
junctions (the classical NC director that hands each servo a ramp per block, Bhatia 1971
§IV.H: "these, therefore, will be the successive inputs to the X and Y servos"). With
``max_acceleration`` a [m/s²] the speed along the path v(s) is trapezoidal: it never
exceeds F_k in block k, changes at most at ±a, and meets the junction speeds below; a
feed change between blocks is made while the faster block runs (the deceleration block
CC' of Bhatia's Fig 38, made by the interpolator instead of the programmer).

Junction speeds v_j (j = 0 … n, v_0 = v_n = 0, the exact stop at the end):

- at most min(F_{j−1}, F_j);
- 0 at an exact stop: a segment with ``exact_stop`` (G9, G61, a pause M0/M1), both ends
  of a rapid (G0) move (Bhatia §III: rapid traverse is a positioning move, executed from
  rest to rest by its own controller, Fig 5);
- the **corner rule** (with ``corner_tolerance`` ε [m] and ``time_constant`` τ [s]):
  Bhatia (§IV.H, the corner at B) says the deviation "depends (for a given servo)
  entirely on how drastic a change is entailed" in the axis feed rates, and models each
  slide's response to a change of ramp by a first-order velocity response
  V_i + ΔV(1 − e^{−t/τ}), τ that of the least responsive slide. Such a slide runs
  behind the reference by its lag ℓ = τv + τ²a along the path (velocity lag, plus what
  a deceleration at a adds: p = r − τṙ + τ²r̈ for a piecewise-quadratic r). At a
  corner that turns the path by θ the lag vector turns with it and changes by
  2 sin(θ/2)·ℓ; the rule holds that change within ε:
  v_j ≤ ε / (2 τ sin(θ_j/2)) − τ a (0 where this is negative: the tool stops; ε is then
  below what the acceleration alone leaves, ≈ τ²a sin θ / e, and a smaller a is needed).
  For the first-order slide itself the contour error of the corner is at most
  ℓ sin θ / e, exactly v τ sin θ / e at constant speed (the tool is e^{−s} sin θ·vτ from
  the new line and (s − 1 + e^{−s}) sin θ·vτ from the old one, s = t/τ; both equal at
  s = 1), and sin θ / e < 2 sin(θ/2): ε bounds it with margin. A reversal (θ = π) slows
  to ε/(2τ) − τa although the first-order model would retrace without error: real
  slides overshoot (Bhatia's B, Fig 38), and the rule keeps them slow there;
- what the acceleration allows: v_{j+1}² ≤ v_j² + 2 a L_j and v_j² ≤ v_{j+1}² + 2 a L_j,
  solved exactly by two cumulative minima in v² (no loop over blocks).

Within block k, from v_a to v_b with peak v_p = min(F_k, √((2 a L + v_a² + v_b²)/2)):
accelerate at a, cruise at v_p, decelerate at a. The sample times k·T are located in the
phases by a binary search, and arc length, position and segment are evaluated for all
samples at once (numpy, no Python loop per sample or per block beyond reading the
segments). The reference starts at t = 0 at the path's start and ends at the first sample
at or after the end of the motion, at the path's end point.

Acceleration is tangential only (along the path); an arc's centripetal v²/R is not
limited (the block's F is what the program asks for).

V-F pulses (Tian et al.): :func:`pulse_reference` turns a reference into the position
each axis' pulse counter reaches under Tian's V-F transformation (``feedtune.loops.
pulse_train``), for pulse-driven axes. With an error limit of at most one BLU and no
acceleration law the counter is the rounded command itself, exactly (no recursion run);
otherwise the recursion is sequential (one period at a time, exactly as the pulse
simulation of one axis).

References
----------
S. Bhatia, *Feed drive design for NC machine tools*, M.S. thesis, University of
Missouri–Rolla, 1971, §IV.H "Operation of the Designed System", Fig 38 (p. 110): feed
rates per block, the rounded corner at B, the deceleration block CC', the
acceleration/deceleration block length S = ∫₀^{4τ} (V_i + ΔV(1 − e^{−t/τ})) dt.
J. Tian, Y. Kamiya, H. Seki, M. Hikizu, "A New Method of Generating Pulse Series for
Numerical Controller", §2 (V-F transformation), eq 2 (acceleration law).
"""

from __future__ import annotations

import math

import numpy as np

from feedtune.machine.path import Path, Reference, SegmentTable

#: at most this many samples in one reference (8 MB per float column)
MAX_SAMPLES = 20_000_000


def _positive(value, name: str, unit: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a number [{unit}], got {type(value).__name__}")
    value = float(value)
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be a positive finite number [{unit}], got {value!r}")
    return value


class _Segments:
    """The path's segments as columns (:class:`SegmentTable`), feeds scaled by the override."""

    def __init__(self, path: Path, feed_override: float = 1.0):
        if not path.segments:
            raise ValueError("an empty path has nothing to interpolate")
        table = SegmentTable.of(path)
        feed = table.feed
        if not np.all(np.isfinite(feed) & (feed > 0)):
            k = int(np.argmin(np.isfinite(feed) & (feed > 0)))
            raise ValueError(f"segment {k} has feed {feed[k]!r}; feeds must be positive [m/s]")
        self.table = table
        self.length, self.start, self.end = table.length, table.start, table.end
        self.is_arc, self.rapid, self.exact_stop = table.arc, table.rapid, table.exact_stop
        self.center, self.radius, self.sweep = table.center, table.radius, table.sweep
        self.angle0 = table.angle
        self.feed = np.where(self.rapid, feed, feed * feed_override)

    def tangents(self) -> tuple[np.ndarray, np.ndarray]:
        """Unit tangents (n, 3) at each segment's start and end (zero for zero length)."""
        return self.table.end_tangents()

    def points(self, k: np.ndarray, s: np.ndarray) -> np.ndarray:
        """Points (m, 3) at local arc length ``s`` of segments ``k``."""
        length = self.length[k]
        with np.errstate(invalid="ignore", divide="ignore"):
            u = np.where(length > 0, s / length, 0.0)
        start = self.start[k]
        out = start + u[:, None] * (self.end[k] - start)
        arc = self.is_arc[k]
        if arc.any():
            ka, ua = k[arc], u[arc]
            angle = self.angle0[ka] + ua * self.sweep[ka]
            r = self.radius[ka]
            out[arc, 0] = self.center[ka, 0] + r * np.cos(angle)
            out[arc, 1] = self.center[ka, 1] + r * np.sin(angle)
        return out


def corner_speed(turn, corner_tolerance: float, time_constant: float,
                 max_acceleration: float = 0.0) -> np.ndarray:
    """Highest speed [m/s] through a corner that turns the path by ``turn`` [rad] (0 = no
    turn, π = reversal): v = ε / (2 τ sin(θ/2)) − τ a, at least 0, so that the lag
    τv + τ²a of a first-order slide with time constant τ [s], decelerating at
    ``max_acceleration`` a [m/s²], changes by at most ``corner_tolerance`` ε [m] as the
    path turns (module docstring; Bhatia 1971 §IV.H). Infinite where the path does not
    turn."""
    jump = 2.0 * np.sin(0.5 * np.asarray(turn, dtype=float))
    with np.errstate(divide="ignore"):
        v = corner_tolerance / (time_constant * jump) - time_constant * max_acceleration
    return np.where(jump > 0, np.maximum(v, 0.0), np.inf)


def transition_length(initial_speed, final_speed, time_constant: float):
    """Bhatia's acceleration/deceleration block length [m]: the distance a slide travels
    while its speed changes from ``initial_speed`` V_i to ``final_speed`` [m/s], modelled
    as a first-order response V_i + ΔV(1 − e^{−t/τ}) taken to completion at 4τ:
    S = ∫₀^{4τ} (V_i + ΔV(1 − e^{−t/τ})) dt = 4τ V_i + ΔV τ (3 + e^{−4})
    (Bhatia 1971 §IV.H, the charts the machine-tool maker supplies; τ [s] is the time
    constant of the least responsive slide)."""
    v_i = np.asarray(initial_speed, dtype=float)
    delta = np.asarray(final_speed, dtype=float) - v_i
    return 4.0 * time_constant * v_i + delta * time_constant * (3.0 + math.exp(-4.0))


def junction_speeds(path: Path, *, max_acceleration: float | None = None,
                    corner_tolerance: float | None = None,
                    time_constant: float | None = None,
                    feed_override: float = 1.0) -> np.ndarray:
    """Speeds [m/s] at the n + 1 block junctions of ``path`` (start, between blocks, end)
    by the rules of the module docstring (arguments as :func:`interpolate`'s); without
    ``max_acceleration`` the feed jumps at junctions and this returns the limits before
    acceleration (0 at exact stops)."""
    return _junctions(_Segments(path, feed_override), max_acceleration, corner_tolerance,
                      time_constant)


def _junctions(seg: _Segments, accel, tolerance, tau) -> np.ndarray:
    n = len(seg.length)
    cap = np.empty(n + 1)
    cap[0] = cap[n] = 0.0
    cap[1:n] = np.minimum(seg.feed[:-1], seg.feed[1:])
    stop = seg.exact_stop | seg.rapid
    stop[:-1] |= seg.rapid[1:]
    cap[1:][stop] = 0.0
    if tolerance is not None:
        t_start, t_end = seg.tangents()
        cosine = np.clip(np.einsum("ij,ij->i", t_end[:-1], t_start[1:]), -1.0, 1.0)
        cap[1:n] = np.minimum(cap[1:n], corner_speed(np.arccos(cosine), tolerance, tau, accel or 0.0))
    if accel is None:
        return cap
    # v² ≤ cap², forward: w_{j+1} ≤ w_j + 2aL_j; backward: w_j ≤ w_{j+1} + 2aL_j. With
    # S_j = 2a Σ_{k<j} L_k the forward pass is w_j = S_j + min_{i≤j}(cap_i² − S_i), the
    # backward one w_j = −S_j + min_{i≥j}(w_i + S_i): exact, no loop over blocks
    reach = np.concatenate([[0.0], np.cumsum(2.0 * accel * seg.length)])
    w = reach + np.minimum.accumulate(cap * cap - reach)
    w = -reach + np.minimum.accumulate((w + reach)[::-1])[::-1]
    return np.sqrt(np.clip(w, 0.0, None))


def interpolate(path: Path, *, period: float, max_acceleration: float | None = None,
                corner_tolerance: float | None = None,
                time_constant: float | None = None,
                feed_override: float = 1.0) -> Reference:
    """Sample the path's motion every ``period``.

    Parameters
    ----------
    path : Path
        The programmed path (feeds [m/s] per segment).
    period : float
        Interpolation period T [s]; sample k is at time k·T.
    max_acceleration : float or None
        Largest tangential acceleration and deceleration a [m/s²]; None: each block at
        its feed from its first sample to its last, the feed jumping between blocks (an
        exact stop then takes no time).
    corner_tolerance : float or None
        ε [m] of the corner rule (needs ``time_constant`` and ``max_acceleration``);
        None: no corner slow-down.
    time_constant : float or None
        τ [s] of the least responsive slide, for the corner rule.
    feed_override : float
        Factor [1] on every programmed feed except rapids (a control's feed override; a
        tuner varies it to trade cycle time against contour error).

    Returns
    -------
    Reference
        ``time`` (n,) [s], ``position`` (n, 3) [m], ``arc_length`` (n,) [m] from the
        path's start, ``segment`` (n,) the block being cut; the last sample is the path's
        end point.
    """
    period = _positive(period, "period", "s")
    accel = None if max_acceleration is None else _positive(max_acceleration, "max_acceleration", "m/s²")
    if (corner_tolerance is None) != (time_constant is None):
        raise ValueError("the corner rule needs both corner_tolerance [m] and time_constant [s]")
    if corner_tolerance is not None:
        corner_tolerance = _positive(corner_tolerance, "corner_tolerance", "m")
        time_constant = _positive(time_constant, "time_constant", "s")
        if accel is None:
            raise ValueError("a corner slow-down needs max_acceleration [m/s²] to slow down with")
    seg = _Segments(path, _positive(feed_override, "feed_override", "1"))
    length = seg.length
    if accel is None:
        peak = seg.feed
        zero = np.zeros_like(length)
        t_acc, t_dec, s_acc, v_a = zero, zero, zero, zero
        accel_value = 0.0
        t_cruise = length / peak
    else:
        v = _junctions(seg, accel, corner_tolerance, time_constant)
        w_a, w_b = v[:-1] ** 2, v[1:] ** 2
        peak = np.sqrt(np.minimum(seg.feed ** 2, 0.5 * (2.0 * accel * length + w_a + w_b)))
        peak = np.maximum(peak, np.maximum(v[:-1], v[1:]))
        s_acc = np.clip((peak ** 2 - w_a) / (2.0 * accel), 0.0, length)
        s_dec = np.clip((peak ** 2 - w_b) / (2.0 * accel), 0.0, length - s_acc)
        v_a = v[:-1]
        t_acc = (peak - v_a) / accel
        t_dec = (peak - v[1:]) / accel
        with np.errstate(invalid="ignore", divide="ignore"):
            t_cruise = np.where(peak > 0, (length - s_acc - s_dec) / peak, 0.0)
        accel_value = accel
    duration = t_acc + t_cruise + t_dec
    block_start = np.concatenate([[0.0], np.cumsum(duration)])
    total = block_start[-1]
    count = int(math.ceil(total / period - 1e-9)) + 1
    if count > MAX_SAMPLES:
        raise ValueError(f"{count} samples ({total:.6g} s at T = {period:g} s); at most {MAX_SAMPLES}")
    time = np.arange(count) * period
    k = np.clip(np.searchsorted(block_start, time, side="right") - 1, 0, len(length) - 1)
    tau = time - block_start[k]
    ta, tc = t_acc[k], t_cruise[k]
    vp, va = peak[k], v_a[k]
    in_acc = tau < ta
    in_dec = tau >= ta + tc
    u = tau - ta - tc
    s = np.where(in_acc, va * tau + 0.5 * accel_value * tau ** 2,
                 s_acc[k] + vp * (tau - ta))
    s = np.where(in_dec, s_acc[k] + vp * tc + vp * u - 0.5 * accel_value * u ** 2, s)
    s = np.clip(s, 0.0, length[k])
    # the last sample, at or (within rounding) just before the end of the motion
    k[-1] = len(length) - 1
    s[-1] = length[-1]
    position = seg.points(k, s)
    cumulative = np.concatenate([[0.0], np.cumsum(length)])
    return Reference(period=period, time=time, position=position,
                     arc_length=cumulative[k] + s, segment=k)


def _vf_counters(command: np.ndarray, value: float, step_limit: float | None) -> np.ndarray:
    """Each axis' V-F pulse counter [pulses] (N, axes) under the whole-pulse command
    ``command`` (N, axes), which moves at most one pulse a period, from rest on its first
    row; ``value`` and ``step_limit`` in pulses (Tian §2, ``feedtune.loops.pulse_train``).

    With an error limit of at most one pulse and no acceleration law the counter is the
    command itself, exactly, so no recursion is run: by induction, if the counter equals
    the command and the accumulator is 0 after period i − 1, the raw error of period i is
    the command's step, −1, 0 or 1; clipped to ±value it is 0 or ±value, and the
    accumulator 0 ± value reaches ±value exactly (no rounding: a float plus zero), so one
    pulse leaves in that period and the accumulator is 0 again. Otherwise the recursion
    runs period by period (``_track``). ``tests/unit/machine/test_interpolate.py`` holds
    both equal, pulse for pulse, to the recursion."""
    from feedtune.loops.pulse_train import _track

    if step_limit is None and value <= 1.0:
        return command.copy()
    out = np.empty_like(command)
    for axis in range(command.shape[1]):
        base = command[0, axis]
        pulses, _ = _track(command[:, axis] - base, value, step_limit)
        out[:, axis] = base + np.cumsum(pulses, dtype=np.int64)
    return out


def pulse_reference(reference: Reference, *, pulse_equivalent: float,
                    error_limit: float | None = None,
                    acceleration_ratio: float | None = None) -> Reference:
    """The reference each pulse-driven axis actually receives under Tian's V-F
    transformation, one V-F generator per axis clocked at 1/``reference.period``.

    The interpolated position is rounded to whole pulses (BLUs) each period and fed to
    ``feedtune.loops.pulse_train``'s V-F recursion (error limit, optional acceleration
    law |e_i − e_{i−1}| ≤ value/k, accumulator); the returned positions are the pulse
    counters times ``pulse_equivalent`` [m], on the BLU grid. The generators lag the
    command; the reference is extended, holding the last command, until every counter has
    reached the end point (``arc_length`` and ``segment`` stay those of the command).

    Parameters
    ----------
    reference : Reference
        From :func:`interpolate`.
    pulse_equivalent : float
        δ, one BLU [m/pulse].
    error_limit : float or None
        Tian's ``value`` [m]; None: one BLU.
    acceleration_ratio : float or None
        k [1] of Tian eq 2; None: no acceleration law.

    Raises
    ------
    ValueError
        When an axis is commanded faster than one pulse per period, δ/T [m/s] (the V-F
        generator sends at most one pulse a period, Tian §2, and would lag).
    """
    delta = _positive(pulse_equivalent, "pulse_equivalent", "m")
    value = 1.0 if error_limit is None else _positive(error_limit, "error_limit", "m") / delta
    step_limit = None if acceleration_ratio is None else value / _positive(
        acceleration_ratio, "acceleration_ratio", "1")
    counts = np.rint(reference.position / delta).astype(np.int64)
    fastest = np.abs(np.diff(counts, axis=0)).max(initial=0)
    if fastest > 1:
        raise ValueError(
            f"an axis moves {fastest} BLU in one period: faster than the V-F generator's one "
            f"pulse per period (δ/T = {delta / reference.period:.6g} m/s); use a shorter period")
    # the generators lag; hold the last command until every counter has reached it
    extra = 16 + int(math.ceil(4 * value * (1 if acceleration_ratio is None else acceleration_ratio)))
    while True:
        command = np.concatenate([counts, np.repeat(counts[-1:], extra, axis=0)])
        out = _vf_counters(command, value, step_limit)
        settled = np.flatnonzero(np.any(out != command[-1], axis=1))
        last = len(counts) - 1 if settled.size == 0 else max(len(counts) - 1, int(settled[-1]) + 1)
        if last < len(command) - 1 or len(command) > MAX_SAMPLES:
            break
        extra *= 4
    if np.any(out[last] != counts[-1]):
        raise ValueError("the V-F generators did not settle on the path's end")
    n = last + 1
    time = np.arange(n) * reference.period
    hold = n - len(counts)
    arc_length = np.concatenate([reference.arc_length, np.repeat(reference.arc_length[-1:], hold)])
    segment = np.concatenate([reference.segment, np.repeat(reference.segment[-1:], hold)])
    return Reference(period=reference.period, time=time, position=out[:n] * delta,
                     arc_length=arc_length[:n], segment=segment[:n])
