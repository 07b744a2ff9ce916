"""Contour metrics of a simulated program: how far the tool is from the programmed path.

The contour error at a sample is the distance of the actual tool point from the nearest
point of the programmed path (:meth:`Path.distance`, nearest point of line or arc), here
computed for all samples at once over the segments near the commanded point: those whose
arc-length span meets [s − 4|E|, s + 4|E|], s the commanded arc length and |E| the
following error's length. The nearest point lies within 2|E| of the commanded point
(|p − q| ≤ |p − r| = |E|), so the window holds it wherever the path between them is at
most twice as long as the straight line; a path that comes back within 2|E| of itself
further along (adjacent passes of a pocket closer than the lag, a closed contour's
overshoot past its end near its start) is measured against the part being cut, not the
nearest pass. ``tests/unit/machine/test_contour.py`` holds it equal to
:meth:`Path.distance` on the test paths.

Reported (SI units): the largest and RMS contour error over the cutting moves (rapids
left out), the largest error near each corner, the overshoot at each stop, each axis'
following error, the cycle time, and at each programmed feed reduction the deceleration
block: the path length over which the tool's speed goes from the old feed to within 2 %
of the new one (Bhatia 1971, ch. 5: CC' of Fig 38, set by the least responsive slide),
beside his estimate from the least responsive slide: his block length
S = 4τV₁ + (V₂ − V₁)τ(3 + e⁻⁴) (:func:`~feedtune.machine.interpolate.transition_length`)
with τ = 1/C_v of the slowest axis, the time constant of the first-order response whose
ramp lag is that axis' (V/C_v).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from feedtune.machine.path import Path, SegmentTable

#: a junction whose tangent turns by more than this is a corner [rad] (0.1°)
CORNER_ANGLE = math.radians(0.1)
#: window half-width in multiples of the following error's length [1] (see the module)
WINDOW_ERRORS = 4.0
#: a speed within this fraction of a feed has reached it [1] (Bhatia's 2 % settling)
SETTLED = 0.02
#: relative margin on :func:`_segment_bound` [1] (and that fraction of a µm): far above the
#: few roundings that separate it from the table's formula, far below any distance told
BOUND_MARGIN = 1e-9
#: samples measured exactly first, and in the first round after, by
#: :func:`largest_contour_distance` (doubling each round) [count]
EXACT_CHUNK = 256




def contour_distance(table: SegmentTable, points: np.ndarray, commanded: np.ndarray,
                     reach: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Contour error [m] of each point (N, 3) and the arc length of its nearest path
    point [m], over the segments whose span meets ``commanded`` ± ``reach`` [m] (N,)."""
    ends = table.begin + table.length
    lo = np.searchsorted(ends, commanded - reach, side="left")
    hi = np.searchsorted(table.begin, commanded + reach, side="right") - 1
    last = len(table.length) - 1
    lo = np.clip(lo, 0, last)
    hi = np.clip(np.maximum(hi, lo), 0, last)
    best = np.full(len(points), np.inf)
    where = np.zeros(len(points))
    centre, radius = table.spheres()
    # from the commanded segment outwards: the near segments set a small best distance
    # early, and a segment whose bounding sphere is farther than it is skipped
    base = np.clip(np.searchsorted(ends, commanded, side="left"), lo, hi)
    reach_segments = int(max(np.max(base - lo), np.max(hi - base))) if len(points) else -1
    alive = np.arange(len(points))
    for r in range(reach_segments + 1):
        alive = alive[(base[alive] - r >= lo[alive]) | (base[alive] + r <= hi[alive])]
        for offset in ((r, -r) if r else (0,)):
            _nearer(table, points, centre, radius, alive, base[alive] + offset, lo, hi,
                    best, where)
    return best, where


def largest_contour_distance(table: SegmentTable, points: np.ndarray,
                             commanded: np.ndarray, reach: np.ndarray,
                             candidates: np.ndarray) -> tuple[int, float, float]:
    """The sample among ``candidates`` (indices) whose :func:`contour_distance` is the
    largest (the first of equals), that distance [m] and its nearest path point's arc
    length [m], without measuring every sample against its whole window.

    A sample's distance is at most its distance from any one segment of its window. The
    commanded segment gives such a bound u₁ for every sample; the samples of largest u₁
    are measured exactly, and their largest distance d₀ is a lower bound of the answer.
    Only samples with u₁ ≥ d₀ can reach it; for those the segment before (where a
    lagging tool usually is), if in the window, tightens the bound to u; the samples
    with u ≥ d₀ are measured exactly in decreasing order of u until the next u is below
    the largest distance found. Equal, sample for sample, to the maximum of
    :func:`contour_distance` over ``candidates`` (a sample's distance does not depend on
    the others)."""
    if candidates.size == 0:
        return 0, 0.0, 0.0
    ends = table.begin + table.length
    last = len(ends) - 1
    at = commanded[candidates]
    # the first segment ending at or after s: in every window (its start is before s,
    # its end after s − reach), as in contour_distance
    base = np.minimum(np.searchsorted(ends, at, side="left"), last)
    bound = _segment_bound(table, base, points[candidates])
    state = {"best": -math.inf, "index": 0, "where": 0.0}

    def measure(chosen):
        """Measure samples ``chosen`` (positions in ``candidates``) exactly."""
        pick = candidates[chosen]
        dist, s = contour_distance(table, points[pick], commanded[pick], reach[pick])
        top = float(np.max(dist))
        tied = np.flatnonzero(dist == top)
        first = int(tied[np.argmin(pick[tied])])
        if top > state["best"] or (top == state["best"] and pick[first] < state["index"]):
            state.update(best=top, index=int(pick[first]), where=float(s[first]))

    k = min(EXACT_CHUNK, bound.size)
    measure(np.argpartition(-bound, k - 1)[:k])
    keep = np.flatnonzero(bound >= state["best"])
    before = base[keep] - 1
    # in the window when it ends within reach of s (contour_distance's first segment)
    inside = (before >= 0) & (ends[np.maximum(before, 0)]
                              >= at[keep] - reach[candidates[keep]])
    if inside.any():
        tighter = _segment_bound(table, before[inside], points[candidates[keep[inside]]])
        bound[keep[inside]] = np.minimum(bound[keep[inside]], tighter)
    keep = keep[bound[keep] >= state["best"]]
    order = keep[np.argsort(-bound[keep], kind="stable")]
    done, chunk = 0, EXACT_CHUNK
    while done < len(order) and bound[order[done]] >= state["best"]:
        measure(order[done:done + chunk])
        done += chunk
        chunk *= 2
    return state["index"], state["best"], state["where"]


def _segment_bound(table: SegmentTable, index: np.ndarray, points: np.ndarray) -> np.ndarray:
    """At least the distance [m] of each point (n, 3) from segment ``index`` (n,) as
    :meth:`SegmentTable.distance` computes it: lines by the projection on the segment
    written for this (no arc length), arcs by the table; raised by
    :data:`BOUND_MARGIN` of itself so that the two formulas' roundings cannot put it
    below the table's."""
    out = np.empty(len(index))
    is_arc = table.arc[index]
    if is_arc.any():
        out[is_arc], _ = table.distance(index[is_arc], points[is_arc])
    line = ~is_arc
    k = index[line]
    start = table.start[k]
    d = table.end[k] - start
    dd = np.einsum("ij,ij->i", d, d)
    w = points[line] - start
    u = np.clip(np.einsum("ij,ij->i", w, d) / np.where(dd > 0, dd, 1.0), 0.0, 1.0)
    w -= u[:, None] * d
    out[line] = np.sqrt(np.einsum("ij,ij->i", w, w))
    return out * (1 + BOUND_MARGIN) + BOUND_MARGIN * 1e-6


def _nearer(table, points, centre, radius, alive, j, lo, hi, best, where) -> None:
    """Update ``best`` and ``where`` of the samples ``alive`` with segments ``j`` (one per
    sample) where j is in the sample's window and its bounding sphere is nearer than best."""
    inside = (j >= lo[alive]) & (j <= hi[alive])
    active, j = alive[inside], j[inside]
    bound = np.linalg.norm(points[active] - centre[j], axis=1) - radius[j]
    near = bound < best[active]
    active, j = active[near], j[near]
    dist, s = table.distance(j, points[active])
    closer = dist < best[active]
    best[active[closer]] = dist[closer]
    where[active[closer]] = s[closer]




def _junction_turn(table: SegmentTable) -> np.ndarray:
    """Angle [rad] between the end tangent of segment i and the start tangent of i + 1."""
    first, last = table.end_tangents()
    a, b = last[:-1], first[1:]
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.einsum("ij,ij->i", a, b))


def step_settling_time(model, samples: int) -> float:
    """2 % settling time [s] of an axis' unit step response (its speed's response to a
    step in commanded speed, the loop being linear), over ``samples`` samples."""
    from feedtune.machine.simulate import simulate_lti

    u = np.ones((samples, 2))
    y = simulate_lti(model.phi, model.gamma[:, :2], model.c, np.array([model.d, 0.0]), u)
    outside = np.flatnonzero(np.abs(y - 1.0) > SETTLED)
    return float((outside[-1] + 1) * model.period) if outside.size else 0.0


def contour_metrics(path: Path, time: np.ndarray, reference: np.ndarray,
                    position: np.ndarray, arc_length: np.ndarray, segment: np.ndarray,
                    program_end: float, settling_times: list[float], lag: float,
                    axes: tuple[str, ...], feed_override: float = 1.0,
                    detail: bool = True, rms: bool = True) -> tuple[dict, np.ndarray | None]:
    """Every contour metric of one simulated program, as a JSON-ready dict (SI units), and
    the contour error [m] at every sample (N,).

    Parameters
    ----------
    path : Path
    time : ndarray (N,)
        Sample times [s], the program and its run-out.
    reference, position : ndarray (N, 3)
        Commanded and actual x, y, z [m].
    arc_length : ndarray (N,)
        Commanded arc length [m].
    segment : ndarray of int (N,)
        Commanded segment.
    program_end : float
        Time the reference reaches the end of the program [s] (the cycle time).
    settling_times : list of float
        Each axis' 2 % step settling time [s] (:func:`step_settling_time`).
    lag : float
        The slowest axis' velocity lag 1/C_v [s].
    axes : tuple of str
        The axes' names, e.g. ``("x", "y")``.
    feed_override : float
        Factor on the path's cutting feeds [1] the reference was made with.
    detail : bool
        False: only the largest and RMS contour error, the cycle time and the following
        errors (what a tuner reads).
    rms : bool
        With ``detail`` False: False leaves out the RMS contour error too, and the largest
        is found by :func:`largest_contour_distance` (the per-sample errors are then not
        returned: None).
    """
    table = SegmentTable.of(path)
    table = dataclasses.replace(table, feed=np.where(table.rapid, table.feed,
                                                     table.feed * feed_override))
    error = reference - position
    size = np.linalg.norm(error, axis=1)
    reach = WINDOW_ERRORS * size + 1e-12
    cutting = ~table.rapid[segment]
    if detail or rms:
        distance, nearest = contour_distance(table, position, arc_length, reach)
        cut = distance[cutting] if cutting.any() else np.zeros(1)
        k_max = int(np.flatnonzero(cutting)[np.argmax(cut)]) if cutting.any() else 0
        largest, largest_at = float(np.max(cut)), float(nearest[k_max])
    else:
        distance = None
        k_max, largest, largest_at = largest_contour_distance(
            table, position, arc_length, reach, np.flatnonzero(cutting))
    slowest = max(settling_times) if settling_times else 0.0
    result = {"max_contour_error": largest}
    if distance is not None:
        result["rms_contour_error"] = float(np.sqrt(np.mean(cut**2)))
    result |= {
        "max_contour_error_at": {"time": float(time[k_max]),
                                 "arc_length": largest_at,
                                 "position": position[k_max].tolist()},
        "cycle_time": float(program_end),
        "following_error": {name: {"max": float(np.max(np.abs(error[:, i]))),
                                   "rms": float(np.sqrt(np.mean(error[:, i] ** 2)))}
                            for i, name in enumerate(axes)},
        "slowest_axis_settling_time": slowest,
        "slowest_axis_lag": float(lag),
    }
    if not detail:
        return result, distance
    result["corners"] = _corners(path, table, distance, nearest, cutting)
    result["stops"] = _stops(path, table, time, reference, position, arc_length, slowest)
    result["deceleration_blocks"] = _decelerations(table, time, nearest, lag)
    return result, distance


def _corners(path, table, distance, nearest, cutting) -> list[dict]:
    """Largest contour error near each corner: over the samples whose nearest path point
    lies closer (in arc length) to this corner than to any other corner or the ends."""
    turns = _junction_turn(table)
    corner = np.flatnonzero(turns > CORNER_ANGLE)
    if corner.size == 0:
        return []
    at = table.begin[corner + 1]
    bounds = np.concatenate([[-np.inf], (at[1:] + at[:-1]) / 2, [np.inf]])
    owner = np.searchsorted(bounds, nearest, side="right") - 1
    largest = np.zeros(corner.size)
    np.maximum.at(largest, owner[cutting], distance[cutting])
    lines = [path.segments[i + 1].source_line for i in corner]
    return [{"segment": int(i + 1), "line": int(line), "position": table.start[i + 1].tolist(),
             "arc_length": float(s), "turn": float(turns[i]), "max_contour_error": float(e)}
            for i, line, s, e in zip(corner, lines, at, largest)]


def _stops(path, table, time, reference, position, arc_length, slowest) -> list[dict]:
    """Overshoot at each stop (an exact stop, a rapid's end, the program's end): the
    largest distance the tool goes past the stop point along the arriving direction,
    beyond what the reference itself commands there, within the slowest axis' settling
    time after the reference arrives."""
    segs = path.segments
    out = []
    ends = table.begin + table.length
    # the first sample at or past each stop by bisection (O(log N) a stop, not a scan of
    # every sample): the running maximum's first crossing of a level is the arc length's
    reached = np.maximum.accumulate(arc_length)
    hold = max(slowest, time[1] - time[0])
    for i, seg in enumerate(segs):
        last = i == len(segs) - 1
        if not (last or seg.exact_stop or table.rapid[i]):
            continue
        k0 = int(np.searchsorted(reached, ends[i] - 1e-12, side="left"))
        if k0 == len(reached):
            continue
        window = slice(k0, int(np.searchsorted(time, time[k0] + hold, side="right")))
        direction = seg.tangent_at(seg.length)[0]
        stop = table.end[i]
        past = (position[window] - stop) @ direction
        commanded = np.maximum(0.0, (reference[window] - stop) @ direction)
        out.append({"segment": int(i), "line": int(seg.source_line), "position": stop.tolist(),
                    "time": float(time[k0]),
                    "overshoot": float(max(0.0, np.max(past - commanded)))})
    return out


def _decelerations(table, time, nearest, lag) -> list[dict]:
    """At each junction where the programmed feed drops: the path length the tool needs
    to slow from within 2 % of the old feed to within 2 % of the new one (measured on the
    tool's nearest-point arc length), and Bhatia's estimate with τ = ``lag`` [s]."""
    from feedtune.machine.interpolate import transition_length

    out = []
    if len(time) < 3:
        return out
    speed = np.gradient(nearest, time)
    for i in range(len(table.feed) - 1):
        v1, v2 = table.feed[i], table.feed[i + 1]
        if table.rapid[i] or table.rapid[i + 1] or not v2 < v1 * (1 - SETTLED):
            continue
        s_c = table.begin[i + 1]
        span = (nearest > table.begin[i]) & (nearest < s_c + table.length[i + 1])
        fast = np.flatnonzero(span & (nearest < s_c) & (speed >= v1 * (1 - SETTLED)))
        after = np.flatnonzero(span & (np.abs(speed - v2) > SETTLED * v2))
        if fast.size == 0 or after.size == 0:
            measured = None
        else:
            measured = float(nearest[min(after[-1] + 1, len(nearest) - 1)] - nearest[fast[-1]])
        out.append({"segment": int(i + 1), "feed_before": float(v1), "feed_after": float(v2),
                    "length": measured, "estimate": float(transition_length(v1, v2, lag))})
    return out
