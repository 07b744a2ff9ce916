"""Built-in paths: geometry against closed forms, Bhatia's Fig 38 profile against the
numbers printed in his §IV.H.

Tolerances: 1e-12 m for geometry built from exact numbers (sizes ≤ 0.2 m, rounding
≈1e-17 m, a BLU 1e-6 m). Bhatia's printed axis feed rates have 4 decimals [in/s] and come
from 4-decimal intermediates (4/6 taken as .6666: .6666 × .8944 = .5962 where the exact
value is .59628), so they agree with ours to one unit of the last digit, 1e-4 in/s.
"""

import math

import numpy as np
import pytest

from feedtune.machine.interpolate import interpolate, junction_speeds, transition_length
from feedtune.machine.path import Arc, Line
from feedtune.machine.paths import (BHATIA_TIME_CONSTANT, INCH, bhatia_profile, circle,
                                    corner, line)

TOL = 1e-12


def test_line():
    path = line(0.05, math.radians(30), feed=0.01, start=(0.01, 0.02))
    (seg,) = path.segments
    assert seg.length == pytest.approx(0.05, abs=TOL)
    np.testing.assert_allclose(seg.end, [0.01 + 0.05 * math.sqrt(3) / 2, 0.02 + 0.025, 0],
                               atol=TOL)
    with pytest.raises(ValueError, match="length"):
        line(0.0, 0.0, feed=0.01)


@pytest.mark.parametrize("ccw", [True, False])
def test_circle(ccw):
    path = circle(0.02, feed=0.01, start_angle=math.pi / 3, ccw=ccw, center=(0.1, 0))
    (arc,) = path.segments
    assert isinstance(arc, Arc) and arc.ccw == ccw
    assert arc.length == pytest.approx(2 * math.pi * 0.02, abs=TOL)
    np.testing.assert_allclose(arc.start, [0.1 + 0.01, 0.02 * math.sqrt(3) / 2, 0], atol=TOL)
    # a quarter of the way round: +90° for ccw, −90° for cw
    q = arc.point_at([arc.length / 4])[0]
    angle = math.pi / 3 + (math.pi / 2 if ccw else -math.pi / 2)
    np.testing.assert_allclose(q[:2], [0.1 + 0.02 * math.cos(angle), 0.02 * math.sin(angle)],
                               atol=TOL)


@pytest.mark.parametrize("turn", [math.radians(45), math.radians(-120), math.radians(170)])
def test_corner(turn):
    path = corner(0.03, 0.2, feed=0.01, turn=turn, exact_stop=True)
    first, second = path.segments
    assert first.exact_stop and not second.exact_stop
    d1 = (first.end - first.start) / first.length
    d2 = (second.end - second.start) / second.length
    cross = d1[0] * d2[1] - d1[1] * d2[0]
    assert math.atan2(cross, d1 @ d2) == pytest.approx(turn, abs=1e-12)
    assert first.length == pytest.approx(0.03, abs=TOL)
    assert second.length == pytest.approx(0.03, abs=TOL)
    with pytest.raises(ValueError, match="turn"):
        corner(0.03, 0.0, feed=0.01, turn=math.pi)


def test_bhatia_fig38_numbers_as_printed():
    """Bhatia 1971 §IV.H, Fig 38 (p. 110): block 1 2.9813" at 40 in/min, tan θ₁ = 2;
    axis feed rates of blocks 1–5 [in/s] as printed; CC' of the order of .010"."""
    path = bhatia_profile()
    rapid, b1, b2, cc, b3, b4, b5 = path.segments
    assert rapid.rapid and not any(s.rapid for s in path.segments[1:])
    assert b1.length == pytest.approx(2.9813 * INCH, abs=TOL)
    printed = {b1: (.2981, .5962), b2: (.5962, .2981), b3: (.0298, .0149),
               b4: (.0304, .0137), b5: (.0313, .0115)}
    for seg, (vx, vy) in printed.items():
        direction = (seg.end - seg.start) / seg.length
        axis_feeds = seg.feed * direction[:2] / INCH  # in/s
        np.testing.assert_allclose(axis_feeds, [vx, vy], atol=1e-4)
    assert b1.feed == b2.feed == pytest.approx(40 * INCH / 60, abs=1e-15)
    assert cc.feed == b3.feed == pytest.approx(2 * INCH / 60, abs=1e-15)
    # CC' lies on block 2's line (same direction), at the slow feed, ≈ .010"
    np.testing.assert_allclose((cc.end - cc.start) / cc.length,
                               (b2.end - b2.start) / b2.length, atol=1e-12)
    assert cc.length / INCH == pytest.approx(0.0100, abs=1e-4)
    assert cc.length == pytest.approx(
        transition_length(40 * INCH / 60, 2 * INCH / 60, BHATIA_TIME_CONSTANT), abs=TOL)


def test_bhatia_corner_at_b_rounded_or_stopped():
    a = 0.5  # m/s²
    rounded = junction_speeds(bhatia_profile(), max_acceleration=a)
    stopped = junction_speeds(bhatia_profile(exact_stop_at_b=True), max_acceleration=a)
    # junction 2 is B (rapid→A is junction 1): 40 in/min through B, or a stop there
    assert rounded[2] == pytest.approx(40 * INCH / 60, abs=1e-12)
    assert stopped[2] == 0.0
    # A is the end of the rapid: a stop either way
    assert rounded[1] == stopped[1] == 0.0
    ref = interpolate(bhatia_profile(exact_stop_at_b=True), period=1e-3, max_acceleration=a)
    assert bhatia_profile().distance(ref.position).max() < TOL
