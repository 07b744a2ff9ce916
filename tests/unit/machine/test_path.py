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
