"""The interpolator: a :class:`Path` → per-axis position references sampled every T.

``interpolate(path: Path, *, period: float, max_acceleration: float | None = None,
corner_tolerance: float | None = None, time_constant: float | None = None,
feed_override: float = 1.0, max_normal_acceleration: float | None = None) -> Reference``

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

Acceleration: ``max_acceleration`` is tangential (along the path). With
``max_normal_acceleration`` a_n [m/s²] an arc's feed is first lowered to √(a_n/κ) (κ = 1/R
on a planar arc, R/(R² + p²) on a helix of pitch p [m/rad]), so that its normal
(centripetal) acceleration v²κ stays within a_n whatever the program and the feed
override ask; the arcs so slowed are listed in the reference's ``summary``. The two
limits are separate: in the acceleration phases at an arc's ends the total acceleration
is √(a² + a_n²) at most.

Stops and in-position waits: :func:`stop_pieces` cuts the same motion at its stops
(the junctions whose speed is 0 above) into pieces that each start at t = 0, and
:func:`join` puts them end to end with a hold after each; the holds are what a control's
in-position check waits (:mod:`feedtune.machine.inposition` finds them from the axes'
simulated errors). :func:`interpolate` itself never waits: without holds an exact stop
takes no time beyond stopping the reference.

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
    """The path's segments as columns (:class:`SegmentTable`), feeds scaled by the override
    and, on arcs, lowered to the normal-acceleration limit."""

    def __init__(self, path: Path, feed_override: float = 1.0,
                 normal_acceleration: float | None = None):
        if not path.segments:
            raise ValueError("an empty path has nothing to interpolate")
        table = SegmentTable.of(path)
        feed = table.feed
        if not np.all(np.isfinite(feed) & (feed > 0)):
            k = int(np.argmin(np.isfinite(feed) & (feed > 0)))
            raise ValueError(f"segment {k} has feed {feed[k]!r}; feeds must be positive [m/s]")
        self.path = path
        self.table = table
        self.length, self.start, self.end = table.length, table.start, table.end
        self.is_arc, self.rapid, self.exact_stop = table.arc, table.rapid, table.exact_stop
        self.center, self.radius, self.sweep = table.center, table.radius, table.sweep
        self.angle0 = table.angle
        self.programmed = np.where(self.rapid, feed, feed * feed_override)
        self.feed = self.programmed
        self.normal_acceleration = normal_acceleration
        if normal_acceleration is not None:
            self.feed = np.minimum(self.programmed, arc_speed_limit(
                self.radius, self.end[:, 2] - self.start[:, 2], self.sweep,
                normal_acceleration))

    def tangents(self) -> tuple[np.ndarray, np.ndarray]:
        """Unit tangents (n, 3) at each segment's start and end (zero for zero length)."""
        return self.table.end_tangents()

    def stops(self) -> np.ndarray:
        """bool (n + 1,): the junctions where the tool stops (module docstring): the
        path's start and end, after an exact-stop block, both ends of a rapid."""
        stop = np.ones(len(self.length) + 1, dtype=bool)
        stop[1:-1] = self.exact_stop[:-1] | self.rapid[:-1] | self.rapid[1:]
        return stop

    def summary(self) -> dict:
        """The arcs whose feed the normal-acceleration limit lowered, JSON-ready."""
        if self.normal_acceleration is None:
            return {}
        slowed = np.flatnonzero(self.feed < self.programmed)
        segments = self.path.segments
        return {"normal_acceleration": self.normal_acceleration,
                "arcs_slowed": [{"segment": int(k), "line": int(segments[k].source_line),
                                 "radius": float(self.radius[k]),
                                 "feed": float(self.programmed[k]),
                                 "limited_feed": float(self.feed[k])} for k in slowed]}

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


def arc_speed_limit(radius, rise, sweep, normal_acceleration: float) -> np.ndarray:
    """Highest speed [m/s] on an arc of ``radius`` R [m] rising ``rise`` Δz [m] over
    ``sweep`` [rad] whose normal (centripetal) acceleration v²κ stays within
    ``normal_acceleration`` a_n [m/s²]: v = √(a_n/κ), κ = R/(R² + p²) the curvature of
    the helix, p = Δz/|sweep| [m/rad] (κ = 1/R on a planar arc: v²/R ≤ a_n). Infinite
    where ``radius`` is 0 (a line)."""
    radius = np.asarray(radius, dtype=float)
    sweep = np.abs(np.asarray(sweep, dtype=float))
    with np.errstate(invalid="ignore", divide="ignore"):
        pitch = np.where(sweep > 0, np.asarray(rise, dtype=float) / sweep, 0.0)
        v = np.sqrt(normal_acceleration * (radius * radius + pitch * pitch) / radius)
    return np.where(radius > 0, v, np.inf)


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
                    feed_override: float = 1.0,
                    max_normal_acceleration: float | None = None) -> np.ndarray:
    """Speeds [m/s] at the n + 1 block junctions of ``path`` (start, between blocks, end)
    by the rules of the module docstring (arguments as :func:`interpolate`'s); without
    ``max_acceleration`` the feed jumps at junctions and this returns the limits before
    acceleration (0 at exact stops)."""
    return _junctions(_Segments(path, feed_override, max_normal_acceleration),
                      max_acceleration, corner_tolerance, time_constant)


def _junctions(seg: _Segments, accel, tolerance, tau) -> np.ndarray:
    n = len(seg.length)
    cap = np.empty(n + 1)
    cap[0] = cap[n] = 0.0
    cap[1:n] = np.minimum(seg.feed[:-1], seg.feed[1:])
    cap[seg.stops()] = 0.0
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


class _Motion:
    """Every block's trapezoid (module docstring): speeds at its ends and peak [m/s],
    phase durations [s], the length of its acceleration phase [m]."""

    def __init__(self, seg: _Segments, accel, tolerance, tau):
        length = seg.length
        if accel is None:
            self.peak = seg.feed
            zero = np.zeros_like(length)
            self.t_acc, self.t_dec, self.s_acc, self.v_a = zero, zero, zero, zero
            self.accel = 0.0
            self.t_cruise = length / self.peak
        else:
            v = _junctions(seg, accel, tolerance, tau)
            w_a, w_b = v[:-1] ** 2, v[1:] ** 2
            peak = np.sqrt(np.minimum(seg.feed ** 2, 0.5 * (2.0 * accel * length + w_a + w_b)))
            peak = np.maximum(peak, np.maximum(v[:-1], v[1:]))
            self.s_acc = np.clip((peak ** 2 - w_a) / (2.0 * accel), 0.0, length)
            s_dec = np.clip((peak ** 2 - w_b) / (2.0 * accel), 0.0, length - self.s_acc)
            self.v_a = v[:-1]
            self.t_acc = (peak - self.v_a) / accel
            self.t_dec = (peak - v[1:]) / accel
            with np.errstate(invalid="ignore", divide="ignore"):
                self.t_cruise = np.where(peak > 0, (length - self.s_acc - s_dec) / peak, 0.0)
            self.peak = peak
            self.accel = accel
        self.duration = self.t_acc + self.t_cruise + self.t_dec

    def sample(self, seg: _Segments, lo: int, hi: int, period: float) -> Reference:
        """Blocks ``lo`` … ``hi`` − 1 every ``period`` from t = 0 at block ``lo``'s start;
        the last sample is block ``hi`` − 1's end."""
        length = seg.length
        block_start = np.concatenate([[0.0], np.cumsum(self.duration[lo:hi])])
        total = block_start[-1]
        count = int(math.ceil(total / period - 1e-9)) + 1
        if count > MAX_SAMPLES:
            raise ValueError(f"{count} samples ({total:.6g} s at T = {period:g} s); at most "
                             f"{MAX_SAMPLES}")
        time = np.arange(count) * period
        k = lo + np.clip(np.searchsorted(block_start, time, side="right") - 1, 0, hi - lo - 1)
        tau = time - block_start[k - lo]
        ta, tc = self.t_acc[k], self.t_cruise[k]
        vp, va = self.peak[k], self.v_a[k]
        in_acc = tau < ta
        in_dec = tau >= ta + tc
        u = tau - ta - tc
        a = self.accel
        s = np.where(in_acc, va * tau + 0.5 * a * tau ** 2, self.s_acc[k] + vp * (tau - ta))
        s = np.where(in_dec, self.s_acc[k] + vp * tc + vp * u - 0.5 * a * u ** 2, s)
        s = np.clip(s, 0.0, length[k])
        # the last sample, at or (within rounding) just before the end of the motion
        k[-1] = hi - 1
        s[-1] = length[hi - 1]
        position = seg.points(k, s)
        return Reference(period=period, time=time, position=position,
                         arc_length=seg.table.begin[k] + s, segment=k, summary=seg.summary())


def _prepared(path, period, max_acceleration, corner_tolerance, time_constant,
              feed_override, max_normal_acceleration):
    """The checked arguments' segments and motion, and the period [s]."""
    period = _positive(period, "period", "s")
    accel = None if max_acceleration is None else _positive(max_acceleration, "max_acceleration", "m/s²")
    if (corner_tolerance is None) != (time_constant is None):
        raise ValueError("the corner rule needs both corner_tolerance [m] and time_constant [s]")
    if corner_tolerance is not None:
        corner_tolerance = _positive(corner_tolerance, "corner_tolerance", "m")
        time_constant = _positive(time_constant, "time_constant", "s")
        if accel is None:
            raise ValueError("a corner slow-down needs max_acceleration [m/s²] to slow down with")
    normal = (None if max_normal_acceleration is None else
              _positive(max_normal_acceleration, "max_normal_acceleration", "m/s²"))
    seg = _Segments(path, _positive(feed_override, "feed_override", "1"), normal)
    return seg, _Motion(seg, accel, corner_tolerance, time_constant), period


def interpolate(path: Path, *, period: float, max_acceleration: float | None = None,
                corner_tolerance: float | None = None,
                time_constant: float | None = None,
                feed_override: float = 1.0,
                max_normal_acceleration: float | None = None) -> Reference:
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
    max_normal_acceleration : float or None
        Largest normal (centripetal) acceleration a_n [m/s²] on arcs: an arc's feed is
        at most √(a_n R) (:func:`arc_speed_limit`), whatever the program and the override
        ask; None: no limit.

    Returns
    -------
    Reference
        ``time`` (n,) [s], ``position`` (n, 3) [m], ``arc_length`` (n,) [m] from the
        path's start, ``segment`` (n,) the block being cut; the last sample is the path's
        end point. ``summary`` lists the arcs the normal-acceleration limit slowed (with
        ``max_normal_acceleration``).
    """
    seg, motion, period = _prepared(path, period, max_acceleration, corner_tolerance,
                                    time_constant, feed_override, max_normal_acceleration)
    return motion.sample(seg, 0, len(seg.length), period)


def stop_pieces(path: Path, *, period: float, max_acceleration: float | None = None,
                corner_tolerance: float | None = None, time_constant: float | None = None,
                feed_override: float = 1.0,
                max_normal_acceleration: float | None = None) -> list[Reference]:
    """The path's motion cut at its stops (exact stops, both ends of rapids), each piece
    sampled every ``period`` from t = 0 at rest at its start to its last sample at rest at
    its stop; ``segment`` and ``arc_length`` are the whole path's. Arguments as
    :func:`interpolate`'s, whose motion each piece is (the tool is at rest at a stop
    either way); :func:`join` puts the pieces together with holds between them."""
    seg, motion, period = _prepared(path, period, max_acceleration, corner_tolerance,
                                    time_constant, feed_override, max_normal_acceleration)
    bounds = np.flatnonzero(seg.stops())
    return [motion.sample(seg, int(lo), int(hi), period) for lo, hi in zip(bounds[:-1], bounds[1:])]


def join(path: Path, pieces: list[Reference], holds) -> Reference:
    """One reference from :func:`stop_pieces`' pieces, the reference held at the end of
    piece p for ``holds[p]`` more samples (an in-position wait, a dwell) before piece
    p + 1 starts from its first sample (its stop point, so the joint is not repeated).

    The summary gains ``in_position``: for each stop, the block that ends there, its
    program line, the stop point [m], the time [s] the reference arrives there and the
    hold [s] after it."""
    parts, stops, offset = [], [], 0
    for p, (piece, hold) in enumerate(zip(pieces, holds)):
        hold = int(hold)
        rows = np.append(np.arange(0 if p == 0 else 1, len(piece.time)),
                         np.full(hold, len(piece.time) - 1))
        parts.append((piece.position[rows], piece.arc_length[rows], piece.segment[rows]))
        arrival = offset + len(rows) - hold - 1
        segment = int(piece.segment[-1])
        stops.append({"segment": segment, "line": int(path.segments[segment].source_line),
                      "position": piece.position[-1].tolist(),
                      "time": float(arrival * piece.period), "hold": float(hold * piece.period)})
        offset += len(rows)
    position, arc, segment = (np.concatenate(column) for column in zip(*parts))
    period = pieces[0].period
    return Reference(period=period, time=np.arange(len(position)) * period, position=position,
                     arc_length=arc, segment=segment,
                     summary={**pieces[0].summary, "in_position": stops})


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
