"""Built-in paths: a line, a circle, a corner, and Bhatia's Fig 38 profile (metres, m/s).

Each function returns a :class:`~feedtune.machine.path.Path` starting where its
docstring says, every segment at the given feed.
"""

from __future__ import annotations

import math

import numpy as np

from feedtune.machine.interpolate import transition_length
from feedtune.machine.path import Arc, Line, Path

INCH = 0.0254  # m
#: Bhatia's servo velocity lag: his ramp response C(t) = t − .01328 − … (§IV, the
#: compensated system's response to a unit ramp) lags by 1/C_v = 0.01328 s; with it his
#: deceleration block formula gives CC' ≈ 0.010" as he states
BHATIA_TIME_CONSTANT = 0.01328  # s


def _direction(angle: float) -> np.ndarray:
    return np.array([math.cos(angle), math.sin(angle), 0.0])


def line(length: float, angle: float, *, feed: float, start=(0.0, 0.0)) -> Path:
    """A straight line of ``length`` [m] at ``angle`` [rad] from the x axis, cut at
    ``feed`` [m/s] from ``start`` [m]."""
    if not length > 0:
        raise ValueError(f"length must be positive [m], got {length!r}")
    p0 = np.append(np.asarray(start, dtype=float)[:2], 0.0)
    return Path((Line(p0, p0 + length * _direction(angle), feed),))


def circle(radius: float, *, feed: float, start_angle: float = 0.0, ccw: bool = True,
           center=(0.0, 0.0)) -> Path:
    """A full circle of ``radius`` [m] about ``center`` [m], starting at ``start_angle``
    [rad] from the x axis, counter-clockwise (G3) when ``ccw``, at ``feed`` [m/s]."""
    if not radius > 0:
        raise ValueError(f"radius must be positive [m], got {radius!r}")
    c = np.append(np.asarray(center, dtype=float)[:2], 0.0)
    p0 = c + radius * _direction(start_angle)
    return Path((Arc(p0, p0, c, ccw=ccw, feed=feed),))


def corner(length: float, angle: float, *, feed: float, turn: float,
           exact_stop: bool = False) -> Path:
    """Two lines of ``length`` [m] each, from the origin: the first at ``angle`` [rad],
    the second turned by ``turn`` [rad] (positive counter-clockwise, |turn| < π) at the
    corner, both at ``feed`` [m/s]; ``exact_stop``: the tool stops at the corner (G9)."""
    if not length > 0:
        raise ValueError(f"length must be positive [m], got {length!r}")
    if not abs(turn) < math.pi:
        raise ValueError(f"turn must lie in (−π, π) [rad], got {turn!r}")
    p0 = np.zeros(3)
    p1 = p0 + length * _direction(angle)
    p2 = p1 + length * _direction(angle + turn)
    return Path((Line(p0, p1, feed, exact_stop=exact_stop), Line(p1, p2, feed)))


def bhatia_profile(*, exact_stop_at_b: bool = False,
                   time_constant: float = BHATIA_TIME_CONSTANT,
                   rapid_feed: float = 0.1) -> Path:
    """Bhatia's Fig 38 profile ("Study of System Operation", thesis p. 110, §IV.H).

    Printed in the text (used as printed): block 1, A → B, 2.9813" at 40 in/min with
    tan θ₁ = 2 (Δx = 1.3333", Δy = 2.6666": his 4-decimal coordinates); the axis feed rates of blocks 2–5 (in/s):
    block 2 (.5962, .2981), 40 in/min; block 3 (.0298, .0149), block 4 (.0304, .0137),
    block 5 (.0313, .0115), each 2 in/min; the rapid traverse to A before block 1; the
    deceleration block CC' between blocks 2 and 3 of length "of the order of .010"",
    which here is Bhatia's own block-length formula (:func:`transition_length`) for
    40 → 2 in/min with ``time_constant`` (default his servo's velocity lag 0.01328 s:
    0.0100").

    Not in the text (the figure itself is not in the thesis text we have; these are our
    choices, not read off the figure): A at (1", 1") from a start at the origin; block 2
    Δx = 2", Δy = 1" (B → C', √5" long; C is CC' before C'); blocks 3, 4, 5 each
    0.5" long. The text says tan θ₂ = 1 at B, but block 2's printed feed rates give
    tan θ₂ = .2981/.5962 = 0.5; we follow the feed rates (they also give the printed
    40 in/min: √(.5962² + .2981²) = .6666"/s).

    Parameters
    ----------
    exact_stop_at_b : bool
        Bhatia's "special code" for a sharp corner: the tool stops at B and block 2
        starts from rest (the overshoot at B of the figure); False: the rounded corner.
    time_constant : float
        τ [s] of the least responsive slide, sizing CC'.
    rapid_feed : float
        Feed of the rapid traverse to A [m/s].

    Returns
    -------
    Path
        Segments: rapid O → A, block 1 (A → B), block 2 (B → C), CC' (C → C'),
        blocks 3, 4, 5.
    """
    fast = 40 * INCH / 60  # 40 in/min [m/s]
    slow = 2 * INCH / 60
    a = np.array([1.0, 1.0, 0.0]) * INCH
    b = a + 2.9813 * INCH * _direction(math.atan(2.0))
    theta2 = math.atan2(0.2981, 0.5962)
    cc = float(transition_length(fast, slow, time_constant))
    c_prime = b + np.array([2.0, 1.0, 0.0]) * INCH
    c = c_prime - cc * _direction(theta2)
    segments = [Line(np.zeros(3), a, rapid_feed, rapid=True),
                Line(a, b, fast, exact_stop=exact_stop_at_b),
                Line(b, c, fast),
                Line(c, c_prime, slow)]
    p = c_prime
    for vx, vy in ((0.0298, 0.0149), (0.0304, 0.0137), (0.0313, 0.0115)):
        q = p + 0.5 * INCH * _direction(math.atan2(vy, vx))
        segments.append(Line(p, q, slow))
        p = q
    return Path(tuple(segments))
