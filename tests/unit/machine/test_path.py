"""Path geometry: lengths, points and the contour distance of lines and arcs.

Tolerances: 1e-12 m against closed forms computed in double precision on paths of size
≈ 0.01–0.1 m (a BLU is 1e-6 m; 1e-12 m is rounding of a few operations on these sizes).
"""

import math

import numpy as np
import pytest

from feedtune.machine.path import Arc, Line, Path


def test_line_length_point_and_distance():
    seg = Line((0, 0), (0.03, 0.04), feed=0.01)
    assert seg.length == pytest.approx(0.05, abs=1e-12)
    np.testing.assert_allclose(seg.point_at([0.025]), [[0.015, 0.02, 0]], atol=1e-12)
    # a point 0.001 m off the line's middle on its normal, and one beyond the end
    normal = np.array([-0.8, 0.6])
    d = seg.distance([[0.015, 0.02] + 0.001 * normal, [0.06, 0.08]])
    np.testing.assert_allclose(d, [0.001, 0.05], atol=1e-12)


def test_quarter_arc_ccw_and_cw():
    ccw = Arc((0.01, 0), (0, 0.01), center=(0, 0), ccw=True, feed=0.01)
    cw = Arc((0.01, 0), (0, 0.01), center=(0, 0), ccw=False, feed=0.01)
    assert ccw.length == pytest.approx(0.01 * math.pi / 2, abs=1e-12)
    assert cw.length == pytest.approx(0.01 * 3 * math.pi / 2, abs=1e-12)
    mid = ccw.point_at([ccw.length / 2])[0]
    np.testing.assert_allclose(mid[:2], 0.01 * np.array([1, 1]) / math.sqrt(2), atol=1e-12)
    # (0.007, 0.007) is inside the ccw quarter, 0.01 − 0.007√2 from the circle; for the cw
    # arc it lies in the missing quarter, so its distance is from the nearer end point
    p = [[0.007, 0.007]]
    assert ccw.distance(p)[0] == pytest.approx(0.01 - 0.007 * math.sqrt(2), abs=1e-12)
    assert cw.distance(p)[0] == pytest.approx(math.hypot(0.003, 0.007), abs=1e-12)


def test_full_circle_when_start_equals_end():
    arc = Arc((0.02, 0), (0.02, 0), center=(0, 0), ccw=True, feed=0.01)
    assert arc.length == pytest.approx(2 * math.pi * 0.02, abs=1e-12)
    assert arc.distance([[-0.021, 0]])[0] == pytest.approx(0.001, abs=1e-12)


def test_arc_end_off_the_circle_is_refused():
    with pytest.raises(ValueError, match="not one circle"):
        Arc((0.01, 0), (0, 0.0101), center=(0, 0), ccw=True, feed=0.01)


def test_path_distance_is_the_nearest_segment_and_gaps_are_refused():
    path = Path((Line((0, 0), (0.01, 0), 0.01), Line((0.01, 0), (0.01, 0.01), 0.01)))
    assert path.length == pytest.approx(0.02, abs=1e-12)
    np.testing.assert_allclose(path.distance([[0.005, 0.001], [0.012, 0.005]]),
                               [0.001, 0.002], atol=1e-12)
    with pytest.raises(ValueError, match="segment 1 starts"):
        Path((Line((0, 0), (0.01, 0), 0.01), Line((0.02, 0), (0.03, 0), 0.01)))


@pytest.mark.parametrize("ccw", [True, False])
def test_tiny_arc_is_tiny_and_only_start_equal_end_is_a_full_circle(ccw):
    """The G-code rule for a centre-format arc: a full circle when the end equals the start
    in the plane (Beckhoff TwinCAT NC I, G02/G03 IJK; a full circle cannot be given by R).
    An arc of 1e-13 rad (below the 1e-12 rad that used to make it a full circle) sweeps
    1e-13 rad in its direction: length R·1e-13 to 1e-12 relative (the angle from two
    atan2 of coordinates ≈ 0.02 m: rounding ≈ 1e-16 rad, 1e-3 of the sweep), and its
    sampled points and distances are those of a point-sized arc."""
    r, delta = 0.02, 1e-13
    sign = 1.0 if ccw else -1.0
    end = (r * math.cos(delta), sign * r * math.sin(delta))
    tiny = Arc((r, 0), end, center=(0, 0), ccw=ccw, feed=0.01)
    assert tiny.sweep == pytest.approx(sign * delta, rel=1e-3)
    assert tiny.length == pytest.approx(r * delta, rel=1e-3)
    # the other way round it is the whole circle but the tiny gap
    other = Arc((r, 0), end, center=(0, 0), ccw=not ccw, feed=0.01)
    assert abs(other.sweep) == pytest.approx(2 * math.pi, abs=1e-12)
    full = Arc((r, 0), (r, 0), center=(0, 0), ccw=ccw, feed=0.01)
    assert full.sweep == sign * 2 * math.pi
    # a point on the circle a quarter turn away is ~R√2 from the tiny arc, on the full one
    p = [[0.0, sign * r]]
    assert tiny.distance(p)[0] == pytest.approx(r * math.sqrt(2), abs=1e-12)
    assert full.distance(p)[0] == pytest.approx(0.0, abs=1e-12)
    from feedtune.machine.interpolate import interpolate
    from feedtune.machine.path import SegmentTable

    path = Path((Line((0, 0), (r, 0), 0.01), tiny))
    ref = interpolate(path, period=1e-3)
    assert ref.arc_length[-1] == pytest.approx(r + r * delta, abs=1e-12)
    assert ref.time[-1] == pytest.approx(2.0, abs=1e-3)  # 0.02 m at 0.01 m/s, not 2πR more
    dist, _ = SegmentTable.of(path).distance(np.array([1]), np.array([[0.0, sign * r, 0.0]]))
    assert dist[0] == pytest.approx(r * math.sqrt(2), abs=1e-12)


def test_arc_with_both_ends_on_one_ray_sweeps_nothing():
    """Start and end at one angle, 1e-10 m apart radially (within the arc's radius check):
    not a full circle (the ends differ), a zero sweep, and every formula finite."""
    arc = Arc((0.02, 0), (0.02 + 1e-10, 0), center=(0, 0), ccw=True, feed=0.01)
    assert arc.sweep == 0.0 and arc.length == 0.0
    np.testing.assert_allclose(arc.point_at([0.0]), [[0.02, 0, 0]], atol=1e-12)
    assert np.all(np.isfinite(arc.tangent_at([0.0])))
    assert arc.distance([[0.03, 0]])[0] == pytest.approx(0.01, abs=1e-9)


def test_gcode_full_circle_still_a_full_circle():
    """G2/G3 with I/J and the end at the start is a full circle, in absolute and
    incremental programs."""
    from feedtune.machine.gcode import parse_program

    for text in ("G21 G90 G0 X10 Y0\nG3 X10 Y0 I-10 J0 F600\n",
                 "G21 G91 G0 X10 Y0\nG2 X0 Y0 I-10 J0 F600\n"):
        (_, circle) = parse_program(text, source="t").path.segments
        assert abs(circle.sweep) == 2 * math.pi
        assert circle.length == pytest.approx(2 * math.pi * 0.01, abs=1e-12)
