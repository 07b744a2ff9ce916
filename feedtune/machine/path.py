"""A programmed tool path: straight lines and circular arcs in the XY plane, in metres.

A part program (:mod:`feedtune.machine.gcode`) or a built-in path becomes a :class:`Path`,
a sequence of :class:`Line` and :class:`Arc` segments, each with its programmed feed
[m/s]. The interpolator turns a path into per-axis references; the contour metrics
measure the distance of the actual tool point from the path with :meth:`Path.distance`.

Coordinates are (x, y, z) [m]; arcs lie in the XY plane (G17) and keep z linear along the
arc (a helix) so that a program with a z move in an arc block is not silently flattened.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np


def _point(p) -> np.ndarray:
    a = np.array(p, dtype=float).ravel()
    if a.size == 2:
        a = np.array([a[0], a[1], 0.0])
    # math.isfinite on three floats: 7x faster than np.isfinite, and a parsed program
    # builds a segment per block (benchmarks/README.md, machine_interpolate)
    if a.size != 3 or not all(math.isfinite(v) for v in a.tolist()):
        raise ValueError(f"a path point needs 2 or 3 finite coordinates [m], got {p!r}")
    return a


@dataclass(frozen=True, eq=False)
class Line:
    """A straight segment from ``start`` to ``end`` [m] at ``feed`` [m/s] (G0/G1); a rapid
    (G0) move has ``rapid`` set and the interpolator stops at its end."""

    start: np.ndarray
    end: np.ndarray
    feed: float
    rapid: bool = False
    #: the program line it came from (1-based), or 0 for a built-in path
    source_line: int = 0
    #: the tool stops at the end of this segment (G9, G61, or a built-in path's sharp corner)
    exact_stop: bool = False

    def __post_init__(self):
        object.__setattr__(self, "start", _point(self.start))
        object.__setattr__(self, "end", _point(self.end))

    @property
    def length(self) -> float:
        """Length [m]."""
        return float(np.linalg.norm(self.end - self.start))

    def point_at(self, s) -> np.ndarray:
        """Points at arc length ``s`` [m] from the start (array (n,) → (n, 3))."""
        s = np.atleast_1d(np.asarray(s, dtype=float))
        length = self.length
        u = s / length if length > 0 else np.zeros_like(s)
        return self.start + u[:, None] * (self.end - self.start)

    def tangent_at(self, s) -> np.ndarray:
        """Unit tangents [1] at arc length ``s`` (n, 3); zero for a zero-length line."""
        s = np.atleast_1d(np.asarray(s, dtype=float))
        length = self.length
        d = (self.end - self.start) / length if length > 0 else np.zeros(3)
        return np.broadcast_to(d, (s.size, 3)).copy()

    def distance(self, points) -> np.ndarray:
        """Distance [m] of each point (n, 2 or 3) from the segment (the nearest point of it)."""
        p = _points(points)
        d = self.end - self.start
        dd = float(d @ d)
        u = np.zeros(len(p)) if dd == 0 else np.clip((p - self.start) @ d / dd, 0.0, 1.0)
        return np.linalg.norm(p - (self.start + u[:, None] * d), axis=1)


@dataclass(frozen=True, eq=False)
class Arc:
    """A circular arc in the XY plane about ``center`` [m], counter-clockwise when ``ccw``
    (G3) or clockwise (G2), at ``feed`` [m/s]; a full circle when ``start`` equals ``end``.

    The radius is |start − center| in XY; ``end`` must lie on the same circle to within
    ``1e-9`` m plus ``1e-6`` of the radius (a G-code arc's end point is rounded to the
    program's resolution), or the arc is refused.
    """

    start: np.ndarray
    end: np.ndarray
    center: np.ndarray
    ccw: bool
    feed: float
    #: the program line it came from (1-based), or 0 for a built-in path
    source_line: int = 0
    #: the tool stops at the end of this arc (G9, G61)
    exact_stop: bool = False

    def __post_init__(self):
        object.__setattr__(self, "start", _point(self.start))
        object.__setattr__(self, "end", _point(self.end))
        c = _point(self.center)
        c[2] = 0.0
        object.__setattr__(self, "center", c)
        r0 = math.hypot(*(self.start - c)[:2])
        r1 = math.hypot(*(self.end - c)[:2])
        if r0 <= 0:
            raise ValueError("an arc needs a start point away from its centre")
        if abs(r1 - r0) > 1e-9 + 1e-6 * r0:
            raise ValueError(
                f"arc end is {r1:.9g} m from the centre, start {r0:.9g} m: not one circle"
            )

    @property
    def radius(self) -> float:
        """Radius R [m]."""
        return math.hypot(*(self.start - self.center)[:2])

    @property
    def sweep(self) -> float:
        """Signed swept angle [rad], in [0, 2π] counter-clockwise, [−2π, 0] clockwise.

        ±2π (a full circle) exactly when the end's x and y are the start's: the G-code
        rule for a centre-format arc ("if the starting point and the end point are equal
        with respect to the working plane, a full circle", Beckhoff TwinCAT NC I,
        "Circular interpolation (G02, G03, IJK, U)"; a full circle cannot be given by R).
        Any other arc sweeps the angle from start to end in its direction, however small
        (0 when the two points lie on one ray from the centre, within the radius check)."""
        if self.end[0] == self.start[0] and self.end[1] == self.start[1]:
            return 2 * math.pi if self.ccw else -2 * math.pi
        a0 = math.atan2(*(self.start - self.center)[1::-1])
        a1 = math.atan2(*(self.end - self.center)[1::-1])
        delta = (a1 - a0) % (2 * math.pi)
        if self.ccw:
            return delta
        return delta - 2 * math.pi if delta > 0 else 0.0

    @property
    def length(self) -> float:
        """Length along the (helical) arc [m]."""
        planar = self.radius * abs(self.sweep)
        return math.hypot(planar, self.end[2] - self.start[2])

    def _angle(self, s) -> tuple[np.ndarray, np.ndarray]:
        s = np.atleast_1d(np.asarray(s, dtype=float))
        length = self.length
        u = s / length if length > 0 else np.zeros_like(s)
        a0 = math.atan2(*(self.start - self.center)[1::-1])
        return a0 + u * self.sweep, u

    def point_at(self, s) -> np.ndarray:
        """Points at arc length ``s`` [m] from the start (n, 3)."""
        a, u = self._angle(s)
        r = self.radius
        z = self.start[2] + u * (self.end[2] - self.start[2])
        return np.column_stack(
            [self.center[0] + r * np.cos(a), self.center[1] + r * np.sin(a), z]
        )

    def tangent_at(self, s) -> np.ndarray:
        """Unit tangents [1] at arc length ``s`` (n, 3)."""
        a, _ = self._angle(s)
        sign = 1.0 if self.ccw else -1.0
        planar = self.radius * abs(self.sweep)
        dz = self.end[2] - self.start[2]
        t = np.column_stack([-sign * np.sin(a) * planar, sign * np.cos(a) * planar,
                             np.full(a.shape, dz)])
        scale = math.hypot(planar, dz)
        return t / scale if scale > 0 else t  # zero for a zero-length arc, as for a line

    def distance(self, points) -> np.ndarray:
        """Distance [m] of each point from the arc: from the circle where the point's angle
        lies within the sweep, else from the nearer end point. XY only for a planar arc;
        a helix is measured in XY plus the z of the nearest angle."""
        p = _points(points)
        rel = p[:, :2] - self.center[:2]
        a0 = math.atan2(*(self.start - self.center)[1::-1])
        ang = np.arctan2(rel[:, 1], rel[:, 0])
        sweep = self.sweep
        # angle travelled from the start in the arc's direction, in [0, 2π)
        travelled = ((ang - a0) if sweep > 0 else (a0 - ang)) % (2 * math.pi)
        inside = travelled <= abs(sweep)
        u = np.clip(travelled / abs(sweep), 0.0, 1.0) if sweep else np.zeros(len(p))
        z = self.start[2] + u * (self.end[2] - self.start[2])
        radial = np.hypot(np.abs(np.hypot(rel[:, 0], rel[:, 1]) - self.radius), p[:, 2] - z)
        ends = np.minimum(np.linalg.norm(p - self.start, axis=1),
                          np.linalg.norm(p - self.end, axis=1))
        return np.where(inside, radial, ends)


Segment = Line | Arc


@dataclass(frozen=True, eq=False)
class Path:
    """A programmed path: segments end to start, in program order."""

    segments: tuple[Segment, ...]

    def __post_init__(self):
        segs = tuple(self.segments)
        object.__setattr__(self, "segments", segs)
        for k in range(1, len(segs)):
            gap = float(np.linalg.norm(segs[k].start - segs[k - 1].end))
            if gap > 1e-9:
                raise ValueError(
                    f"segment {k} starts {gap:.3g} m from where segment {k - 1} ends"
                )

    @property
    def length(self) -> float:
        """Total length [m]."""
        return float(sum(seg.length for seg in self.segments))

    def distance(self, points) -> np.ndarray:
        """Contour error [m]: distance of each point (n, 2 or 3) from the nearest point of
        any segment (rapid moves included; a caller excludes them by slicing the path)."""
        p = _points(points)
        if not self.segments:
            raise ValueError("an empty path has no distance")
        out = np.full(len(p), np.inf)
        for seg in self.segments:
            out = np.minimum(out, seg.distance(p))
        return out


def _points(points) -> np.ndarray:
    p = np.asarray(points, dtype=float)
    if p.ndim == 1:
        p = p[None, :]
    if p.shape[1] == 2:
        p = np.column_stack([p, np.zeros(len(p))])
    if p.shape[1] != 3:
        raise ValueError(f"points must be (n, 2) or (n, 3) [m], got shape {p.shape}")
    return p


@dataclass(frozen=True)
class SegmentTable:
    """A path's segments as arrays (M segments): what the interpolator and the contour
    metrics read, for vectorised end tangents, points and distances."""

    arc: np.ndarray  # bool (M,)
    start: np.ndarray  # (M, 3) [m]
    end: np.ndarray  # (M, 3) [m]
    center: np.ndarray  # (M, 3) [m]
    radius: np.ndarray  # (M,) [m], 0 for a line
    angle: np.ndarray  # (M,) start angle [rad]
    sweep: np.ndarray  # (M,) signed sweep [rad]
    length: np.ndarray  # (M,) [m]
    begin: np.ndarray  # (M,) arc length at the segment's start [m]
    rapid: np.ndarray  # bool (M,)
    feed: np.ndarray  # (M,) [m/s]
    exact_stop: np.ndarray  # bool (M,)

    @classmethod
    def of(cls, path: Path) -> SegmentTable:
        """The table of ``path`` (the last few paths' tables are kept: a tuner runs one
        path many times)."""
        return _table(path)

    @classmethod
    def build(cls, path: Path) -> SegmentTable:
        segs = path.segments
        arc = np.array([isinstance(s, Arc) for s in segs], dtype=bool)
        length = np.array([s.length for s in segs])
        zero3 = np.zeros(3)
        return cls(
            arc=arc,
            start=np.array([s.start for s in segs]).reshape(-1, 3),
            end=np.array([s.end for s in segs]).reshape(-1, 3),
            center=np.array([s.center if a else zero3 for s, a in zip(segs, arc)]).reshape(-1, 3),
            radius=np.array([s.radius if a else 0.0 for s, a in zip(segs, arc)]),
            angle=np.array([math.atan2(*(s.start - s.center)[1::-1]) if a else 0.0
                            for s, a in zip(segs, arc)]),
            sweep=np.array([s.sweep if a else 0.0 for s, a in zip(segs, arc)]),
            length=length,
            begin=np.concatenate([[0.0], np.cumsum(length)[:-1]]),
            rapid=np.array([isinstance(s, Line) and s.rapid for s in segs], dtype=bool),
            feed=np.array([float(s.feed) for s in segs]),
            exact_stop=np.array([bool(s.exact_stop) for s in segs], dtype=bool),
        )

    def end_tangents(self) -> tuple[np.ndarray, np.ndarray]:
        """Unit tangents (M, 3) at every segment's start and end, as ``tangent_at``."""
        d = self.end - self.start
        norm = np.linalg.norm(d, axis=1)
        line = d / np.where(norm > 0, norm, 1.0)[:, None]
        turn = np.sign(self.sweep)
        planar = self.radius * np.abs(self.sweep)
        dz = d[:, 2]
        scale = np.hypot(planar, dz)
        scale = np.where(scale > 0, scale, 1.0)

        def arc_tangent(angle):
            return np.column_stack([-turn * np.sin(angle) * planar, turn * np.cos(angle) * planar,
                                    dz]) / scale[:, None]

        first = np.where(self.arc[:, None], arc_tangent(self.angle), line)
        last = np.where(self.arc[:, None], arc_tangent(self.angle + self.sweep), line)
        return first, last

    def spheres(self) -> tuple[np.ndarray, np.ndarray]:
        """Centre (M, 3) and radius (M,) [m] of a sphere holding each segment."""
        centre = 0.5 * (self.start + self.end)
        centre[self.arc, :2] = self.center[self.arc, :2]
        half = 0.5 * np.linalg.norm(self.end - self.start, axis=1)
        radius = np.where(self.arc, np.hypot(self.radius, 0.5 * np.abs(self.end[:, 2]
                                                                      - self.start[:, 2])),
                          half)
        return centre, radius * (1 + 1e-12) + 1e-15

    def distance(self, index: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(distance [m], arc length of the nearest point [m]) of each point (n, 3) from
        segment ``index`` (n,), as :meth:`Line.distance` and :meth:`Arc.distance`."""
        dist = np.empty(len(index))
        where = np.empty(len(index))
        is_arc = self.arc[index]
        for pick, formula in ((~is_arc, self._line), (is_arc, self._arc)):
            if pick.any():
                k = index[pick]
                d, u = formula(k, points[pick])
                dist[pick] = d
                where[pick] = self.begin[k] + u * self.length[k]
        return dist, where

    def _line(self, index, points):
        start, end = self.start[index], self.end[index]
        d = end - start
        dd = np.einsum("ij,ij->i", d, d)
        safe = np.where(dd > 0, dd, 1.0)
        u = np.where(dd > 0, np.clip(np.einsum("ij,ij->i", points - start, d) / safe,
                                     0.0, 1.0), 0.0)
        return np.linalg.norm(points - (start + u[:, None] * d), axis=1), u

    def _arc(self, index, points):
        start, end = self.start[index], self.end[index]
        rel = points[:, :2] - self.center[index, :2]
        sweep = self.sweep[index]
        ang = np.arctan2(rel[:, 1], rel[:, 0])
        a0 = self.angle[index]
        travelled = np.where(sweep > 0, ang - a0, a0 - ang) % (2 * math.pi)
        inside = travelled <= np.abs(sweep)
        u = np.clip(travelled / np.where(sweep != 0, np.abs(sweep), 1.0), 0.0, 1.0)
        z = start[:, 2] + u * (end[:, 2] - start[:, 2])
        radial = np.hypot(np.abs(np.hypot(rel[:, 0], rel[:, 1]) - self.radius[index]),
                          points[:, 2] - z)
        to_start = np.linalg.norm(points - start, axis=1)
        to_end = np.linalg.norm(points - end, axis=1)
        u = np.where(inside, u, np.where(to_start <= to_end, 0.0, 1.0))
        return np.where(inside, radial, np.minimum(to_start, to_end)), u


@functools.lru_cache(maxsize=8)
def _table(path: Path) -> SegmentTable:
    return SegmentTable.build(path)  # a Path hashes by identity (eq=False)


@dataclass(frozen=True, eq=False)
class Reference:
    """Per-axis position references from the interpolator, sampled every ``period``.

    Attributes
    ----------
    period : float
        Interpolation (and sampling) period T [s].
    time : ndarray (n,)
        Sample times k·T [s].
    position : ndarray (n, 3)
        Commanded x, y, z [m] at each sample.
    arc_length : ndarray (n,)
        Commanded distance along the path [m] at each sample.
    segment : ndarray of int (n,)
        Index of the path segment being cut at each sample.
    summary : dict
        What the interpolator changed from the program, JSON-ready (SI units): arcs whose
        feed the normal-acceleration limit lowered, the in-position holds at exact stops
        (:func:`feedtune.machine.interpolate.interpolate`,
        :func:`feedtune.machine.inposition.settled_reference`).
    """

    period: float
    time: np.ndarray
    position: np.ndarray
    arc_length: np.ndarray
    segment: np.ndarray
    summary: dict = field(default_factory=dict)

    def resampled(self, ratio: int) -> Reference:
        """This reference every ``period``/``ratio``: linear between its points (Sato's
        linear interpolation), every ``ratio``-th sample one of them; the segment is the
        one of the interpolator's point at or before each sample."""
        if ratio == 1:
            return self
        period = self.period / ratio
        time = np.arange((len(self.time) - 1) * ratio + 1) * period
        position = np.column_stack([np.interp(time, self.time, self.position[:, i])
                                    for i in range(3)])
        arc = np.interp(time, self.time, self.arc_length)
        segment = self.segment[np.minimum(np.arange(len(time)) // ratio,
                                          len(self.segment) - 1)]
        return Reference(period=period, time=time, position=position, arc_length=arc,
                         segment=segment, summary=self.summary)
