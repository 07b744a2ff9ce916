"""The interpolator: feed per block, acceleration limit, path length, on-path samples,
exact stops, the corner rule, Bhatia's block length, Tian's V-F pulses.

Tolerance scales. Paths are 0.01–0.1 m long with feeds 1e-3–0.05 m/s and T = 1e-4–1e-3 s:
- on the path: 1e-12 m (a sample is a few float operations on coordinates ≤ 0.1 m,
  rounding ≈1e-17 m; a BLU is 1e-6 m);
- speeds from first differences of arc length: arc lengths carry ≈1e-17 m of rounding,
  divided by T ≥ 1e-4 s: 1e-9 m/s is far above rounding, far below any feed (≥ 1e-3 m/s);
- accelerations from second differences: 1e-17 m / T² (1e-8 s²) ≈ 1e-9 m/s²; we allow
  1e-6 m/s², six orders below the limits tested (0.1–2 m/s²).
"""

import math
from pathlib import Path as FilePath

import numpy as np
import pytest
from scipy import signal

from feedtune.machine.gcode import parse_program
from feedtune.machine.interpolate import (corner_speed, interpolate, junction_speeds,
                                          pulse_reference, transition_length)
from feedtune.machine.path import Arc, Line, Path
from feedtune.machine.paths import corner

DATA = FilePath(__file__).parents[2] / "data" / "gcode"
ON_PATH = 1e-12  # m
SPEED = 1e-9  # m/s
ACCEL = 1e-6  # m/s²


def program(name: str) -> Path:
    return parse_program((DATA / name).read_text(), source=name).path


def speeds(ref):
    return np.diff(ref.arc_length) / ref.period


@pytest.mark.parametrize("name", ["pocket_mm_absolute.ngc", "arcs_r_and_ij.ngc",
                                  "spiral_mm.ngc", "incremental_arcs_inch.ngc"])
@pytest.mark.parametrize("accel", [None, 0.5])
def test_on_path_and_whole_length(name, accel):
    path = program(name)
    ref = interpolate(path, period=1e-3, max_acceleration=accel)
    assert path.distance(ref.position).max() < ON_PATH
    assert ref.arc_length[-1] == pytest.approx(path.length, abs=ON_PATH)
    np.testing.assert_allclose(ref.position[-1], path.segments[-1].end, atol=ON_PATH)
    np.testing.assert_allclose(ref.position[0], path.segments[0].start, atol=ON_PATH)
    assert np.all(np.diff(ref.arc_length) >= 0)
    np.testing.assert_allclose(ref.time, np.arange(len(ref.time)) * 1e-3, atol=1e-15)
    # each sample's point is the point at its arc length on its own segment
    starts = np.concatenate([[0.0], np.cumsum([s.length for s in path.segments])])
    for k in np.unique(ref.segment):
        rows = ref.segment == k
        pts = path.segments[k].point_at(ref.arc_length[rows] - starts[k])
        np.testing.assert_allclose(ref.position[rows], pts, atol=ON_PATH)


def test_feed_held_per_block_without_acceleration_limit():
    path = program("pocket_mm_absolute.ngc")
    ref = interpolate(path, period=1e-3)
    v = speeds(ref)
    seg = ref.segment
    inside = seg[1:] == seg[:-1]  # both samples in one block
    feeds = np.array([s.feed for s in path.segments])[seg[:-1]]
    inside[-1] = False  # the last interval ends early, at the path's end point
    np.testing.assert_allclose(v[inside], feeds[inside], atol=SPEED)
    # the motion takes Σ L_k / F_k, rounded up to a whole period
    duration = sum(s.length / s.feed for s in path.segments)
    assert ref.time[-1] - duration == pytest.approx(0.5e-3, abs=0.5e-3 + 1e-12)


def test_acceleration_limit_and_feeds_respected():
    path = program("arcs_r_and_ij.ngc")
    a = 0.2
    ref = interpolate(path, period=1e-3, max_acceleration=a)
    v = speeds(ref)
    accel = np.diff(v) / ref.period
    assert np.abs(accel).max() <= a + ACCEL
    # and it is used: the peak is the limit itself (a trapezoid, not a gentler ramp)
    assert np.abs(accel).max() > 0.99 * a
    feeds = np.array([s.feed for s in path.segments])
    # no sample interval is faster than the faster of the two blocks it touches
    top = np.maximum(feeds[ref.segment[:-1]], feeds[ref.segment[1:]])
    assert np.all(v <= top + SPEED)
    # cruise: at least one period at each block's feed in the long blocks
    for k, seg in enumerate(path.segments):
        if seg.length > 0.01:
            rows = (ref.segment[:-1] == k) & (ref.segment[1:] == k)
            assert np.abs(v[rows] - seg.feed).min() < SPEED


def test_trapezoid_on_one_line_has_the_closed_form_duration():
    # a line of L at feed F, a: t = L/F + F/a (accelerate and decelerate F/a each)
    L, F, a = 0.05, 0.02, 0.5
    path = Path((Line((0, 0), (L, 0), F),))
    ref = interpolate(path, period=1e-4, max_acceleration=a)
    assert ref.time[-1] == pytest.approx(L / F + F / a, abs=1e-4)
    # a short line never reaches F: a triangle of peak √(aL) and time 2√(L/a)
    short = Path((Line((0, 0), (4e-4, 0), F),))
    ref = interpolate(short, period=1e-5, max_acceleration=a)
    assert ref.time[-1] == pytest.approx(2 * math.sqrt(4e-4 / a), abs=1e-5)
    assert speeds(ref).max() <= math.sqrt(a * 4e-4) + SPEED


def test_exact_stops_at_g9_rapid_ends_and_end():
    text = "G21 G1 X10 F600\nG9 Y10\nX20\nG0 X30\nG1 Y20\n"
    path = parse_program(text, source="t").path
    v = junction_speeds(path, max_acceleration=0.5)
    # junctions: start, X10 (turn 90°, feeds meet), G9 stop, before G0, after G0, end
    assert v[0] == 0 and v[2] == 0 and v[3] == 0 and v[4] == 0 and v[5] == 0
    assert v[1] == pytest.approx(0.01, abs=SPEED)
    ref = interpolate(path, period=1e-4, max_acceleration=0.5)
    sp = speeds(ref)
    for j in (2, 3, 4):
        at = np.searchsorted(ref.arc_length, sum(s.length for s in path.segments[:j]))
        # within a period of the stop the speed is at most a·T
        assert sp[max(at - 2, 0):at + 1].min() <= 0.5 * 1e-4 + SPEED


def test_corner_rule_speed_and_where_it_applies():
    eps, tau, a, F = 1e-5, 0.005, 0.1, 0.02
    for turn in (math.radians(20), math.radians(90), math.radians(150)):
        path = corner(0.02, 0.3, feed=F, turn=turn)
        v = junction_speeds(path, max_acceleration=a, corner_tolerance=eps, time_constant=tau)
        expected = eps / (2 * tau * math.sin(turn / 2)) - tau * a
        assert 0 < expected < F
        assert v[1] == pytest.approx(expected, rel=1e-12)
        ref = interpolate(path, period=1e-4, max_acceleration=a, corner_tolerance=eps,
                          time_constant=tau)
        at = np.searchsorted(ref.arc_length, 0.02)
        # the slowest interval near the corner is within a·T of the corner speed
        assert abs(speeds(ref)[at - 2:at + 2].min() - expected) <= a * 1e-4
    # a straight continuation keeps the feed
    straight = Path((Line((0, 0), (0.01, 0), F), Line((0.01, 0), (0.02, 0), F)))
    v = junction_speeds(straight, max_acceleration=a, corner_tolerance=eps, time_constant=tau)
    assert v[1] == pytest.approx(F, abs=SPEED)
    # tangent line → arc: no turn, no slow-down
    tangent = Path((Line((0, 0), (0.01, 0), F),
                    Arc((0.01, 0), (0.02, 0.01), (0.01, 0.01), ccw=True, feed=F)))
    v = junction_speeds(tangent, max_acceleration=a, corner_tolerance=eps, time_constant=tau)
    assert v[1] == pytest.approx(F, abs=SPEED)
    # an acceleration whose lag τ²a alone turns by more than ε: the tool stops
    v = junction_speeds(corner(0.02, 0.3, feed=F, turn=math.radians(90)), max_acceleration=1.0,
                        corner_tolerance=eps, time_constant=tau)
    assert v[1] == 0.0


def test_corner_speed_formula():
    assert corner_speed(math.pi, 1e-5, 0.01) == pytest.approx(1e-5 / 0.02, rel=1e-15)
    assert corner_speed(math.pi, 1e-5, 0.01, 0.01) == pytest.approx(5e-4 - 1e-4, rel=1e-12)
    assert np.isinf(corner_speed(0.0, 1e-5, 0.01))


def first_order(ref, tau):
    """Each axis through 1/(1 + τs), exact for an input linear between samples (FOH)."""
    sys = signal.cont2discrete(([1.0], [tau, 1.0]), ref.period, method="foh")
    b, a = np.ravel(sys[0]), np.ravel(sys[1])
    out = np.empty_like(ref.position)
    for axis in range(3):
        x = ref.position[:, axis]
        zi = signal.lfilter_zi(b, a) * x[0]
        out[:, axis], _ = signal.lfilter(b, a, x, zi=zi)
    return out


@pytest.mark.parametrize("turn_deg", [30, 90, 135])
def test_corner_rule_holds_a_first_order_slide_within_tolerance(turn_deg):
    """Bhatia's chart model (first-order slide of time constant τ) cutting the corner:
    with the rule its contour error stays within ε; without it, at constant feed, it is
    the closed form v τ sin θ / e, above ε (so the rule is what holds it)."""
    eps, tau, a, F, T = 1e-5, 0.005, 0.1, 0.02, 1e-4
    turn = math.radians(turn_deg)
    path = corner(0.03, 0.2, feed=F, turn=turn)
    slowed = interpolate(path, period=T, max_acceleration=a, corner_tolerance=eps,
                         time_constant=tau)
    assert path.distance(first_order(slowed, tau)).max() <= eps
    plain = interpolate(path, period=T)
    err = path.distance(first_order(plain, tau))
    closed_form = F * tau * math.sin(turn) / math.e
    # FOH makes the filter exact at the samples; the sampled maximum misses the true one
    # by a second-order amount in T/τ = 0.02: 1e-3 relative
    assert err.max() == pytest.approx(closed_form, rel=1e-3)
    assert err.max() > eps


def test_bhatia_deceleration_block_of_fig38_is_ten_thousandths():
    """Bhatia §IV.H: CC' (40 → 2 in/min) 'is actually of the order of .010"'; with his
    servo's ramp lag 0.01328 s (C(t) = t − .01328 − …) as τ the chart formula gives
    0.01003"; 4 significant digits of .01328 → 1e-5 inch."""
    s = transition_length(40 / 60, 2 / 60, 0.01328)  # in/s → inch
    assert s == pytest.approx(0.0100, abs=1e-4)
    # the formula is the integral it states
    from scipy.integrate import quad

    v_i, v_f, tau = 0.3, 0.05, 0.02
    value, _ = quad(lambda t: v_i + (v_f - v_i) * (1 - math.exp(-t / tau)), 0, 4 * tau)
    assert transition_length(v_i, v_f, tau) == pytest.approx(value, rel=1e-12)


def test_pulse_reference_on_the_blu_grid_and_settles():
    blu = 1e-6
    path = corner(0.004, 0.4, feed=0.005, turn=1.2)
    ref = interpolate(path, period=1e-4, max_acceleration=0.5)
    for kw in ({}, {"error_limit": 4 * blu}, {"error_limit": 4 * blu, "acceleration_ratio": 8}):
        pulses = pulse_reference(ref, pulse_equivalent=blu, **kw)
        counts = pulses.position / blu
        np.testing.assert_allclose(counts, np.rint(counts), atol=1e-9)
        # one pulse per period at most, on every axis
        assert np.abs(np.diff(np.rint(counts), axis=0)).max() <= 1
        np.testing.assert_allclose(pulses.position[-1], np.rint(path.segments[-1].end / blu) * blu,
                                   atol=1e-12)
        n = len(ref.time)
        lag = np.abs(pulses.position[:n] - ref.position).max()
        # Tian §2: the error stays within the error limit (value) plus the BLU rounding
        limit = kw.get("error_limit", blu)
        assert lag <= limit + blu
    # value = one BLU: the counter is the rounded command itself (pulse in the same period)
    exact = pulse_reference(ref, pulse_equivalent=blu)
    np.testing.assert_allclose(exact.position[:len(ref.time)], np.rint(ref.position / blu) * blu,
                               atol=1e-12)


def test_pulse_reference_refuses_faster_than_one_pulse_per_period():
    path = corner(0.004, 0.4, feed=0.05, turn=1.2)
    ref = interpolate(path, period=1e-3)
    with pytest.raises(ValueError, match="one pulse per period"):
        pulse_reference(ref, pulse_equivalent=1e-6)


@pytest.mark.parametrize("kw, match", [
    ({"period": 0.0}, "period"),
    ({"period": float("nan")}, "period"),
    ({"period": 1e-3, "max_acceleration": -1.0}, "max_acceleration"),
    ({"period": 1e-3, "corner_tolerance": 1e-5}, "both"),
    ({"period": 1e-3, "corner_tolerance": 1e-5, "time_constant": 0.01}, "max_acceleration"),
])
def test_bad_arguments(kw, match):
    with pytest.raises(ValueError, match=match):
        interpolate(corner(0.01, 0.0, feed=0.01, turn=1.0), **kw)


def test_feed_override_scales_cutting_feeds_not_rapids():
    path = parse_program("G21 G0 X10\nG1 X20 F600\n", source="t", rapid_feed=0.1).path
    ref = interpolate(path, period=1e-4, feed_override=0.5)
    v = speeds(ref)
    seg = ref.segment
    inside = (seg[1:] == seg[:-1])
    inside[-1] = False
    np.testing.assert_allclose(v[inside & (seg[:-1] == 0)], 0.1, atol=SPEED)
    np.testing.assert_allclose(v[inside & (seg[:-1] == 1)], 0.005, atol=SPEED)
    with pytest.raises(ValueError, match="feed_override"):
        interpolate(path, period=1e-4, feed_override=0.0)


def test_junction_speeds_on_short_blocks_follow_the_acceleration_from_both_stops():
    """50 collinear blocks of 0.1 mm at F = 0.05 m/s, a = 0.5 m/s²: reaching F takes
    F²/2a = 2.5 mm, so junction j (at s_j) is min(F, √(2a s_j), √(2a (L − s_j)))."""
    F, a, step, n = 0.05, 0.5, 1e-4, 50
    pts = [(k * step, 0.0) for k in range(n + 1)]
    path = Path(tuple(Line(p, q, F) for p, q in zip(pts[:-1], pts[1:])))
    s = np.arange(n + 1) * step
    expected = np.minimum(F, np.sqrt(2 * a * np.minimum(s, n * step - s)))
    # v² is summed over the blocks: rounding ≈1e-18 m²/s², 1e-12 m/s on v ≥ 0.01 m/s
    np.testing.assert_allclose(junction_speeds(path, max_acceleration=a), expected, atol=1e-9)
    ref = interpolate(path, period=1e-4, max_acceleration=a)
    assert np.abs(np.diff(speeds(ref))).max() / 1e-4 <= a + ACCEL


def small_arc_path(radius: float, feed: float) -> Path:
    """A line along x, a quarter arc of ``radius`` [m] turning left, a line along y."""
    p1 = (0.01, 0.0)
    p2 = (0.01 + radius, radius)
    return Path((Line((0, 0), p1, feed), Arc(p1, p2, center=(0.01, radius), ccw=True, feed=feed),
                 Line(p2, (0.01 + radius, radius + 0.01), feed)))


def test_arc_speed_limit_is_the_curvature_of_the_helix():
    """v = √(a_n/κ): κ = 1/R on a plane arc; on a helix κ = R/(R² + p²), checked against
    the curvature |dT/ds| of Arc.tangent_at by a central difference (h = 1e-6 m on a
    2 mm radius: truncation (h/R)² ≈ 2.5e-7 relative, rounding 1e-16/1e-6 = 1e-10)."""
    from feedtune.machine.interpolate import arc_speed_limit

    assert arc_speed_limit(0.002, 0.0, 1.0, 0.5) == pytest.approx(math.sqrt(0.5 * 0.002), rel=1e-15)
    assert np.isinf(arc_speed_limit(0.0, 0.0, 0.0, 0.5))
    helix = Arc((0.002, 0, 0), (0, 0.002, 0.003), center=(0, 0), ccw=True, feed=0.01)
    h, s = 1e-6, helix.length / 2
    kappa = np.linalg.norm(helix.tangent_at(s + h)[0] - helix.tangent_at(s - h)[0]) / (2 * h)
    limit = arc_speed_limit(helix.radius, 0.003, helix.sweep, 0.5)
    assert 0.5 / limit ** 2 == pytest.approx(kappa, rel=1e-6)


def test_small_radius_arc_is_slowed_to_the_normal_acceleration_limit():
    """F = 50 mm/s round R = 2 mm is v²/R = 1.25 m/s²; with a_n = 0.5 m/s² the arc is cut
    at √(a_n R) = 31.6 mm/s (speeds on it within SPEED of that, v²/R within a_n), the lines
    at 50 mm/s, and the summary names the arc; an arc of 20 mm (√(a_n R) = 0.1 m/s > F)
    is left at F and not listed. Without the limit the small arc runs at 50 mm/s."""
    a_n, feed, T = 0.5, 0.05, 1e-4
    for accel in (None, 2.0):
        ref = interpolate(small_arc_path(0.002, feed), period=T, max_acceleration=accel,
                          max_normal_acceleration=a_n)
        v = speeds(ref)
        on_arc = (ref.segment[:-1] == 1) & (ref.segment[1:] == 1)
        limit = math.sqrt(a_n * 0.002)
        assert v[on_arc].max() <= limit + SPEED
        assert v[on_arc].max() ** 2 / 0.002 <= a_n * (1 + 1e-6)
        assert v.max() == pytest.approx(feed, abs=SPEED)  # the lines keep their feed
        (slowed,) = ref.summary["arcs_slowed"]
        assert slowed["segment"] == 1 and slowed["radius"] == pytest.approx(0.002, abs=1e-15)
        assert slowed["feed"] == feed and slowed["limited_feed"] == pytest.approx(limit, rel=1e-15)
    wide = interpolate(small_arc_path(0.02, feed), period=T, max_normal_acceleration=a_n)
    assert wide.summary["arcs_slowed"] == []
    plain = interpolate(small_arc_path(0.002, feed), period=T)
    on_arc = (plain.segment[:-1] == 1) & (plain.segment[1:] == 1)
    assert speeds(plain)[on_arc].max() == pytest.approx(feed, abs=SPEED)
    assert plain.summary == {}


def test_normal_acceleration_limit_in_a_machine_run():
    """Through the machine spec: the arc of a G-code program with R = 2 mm is listed in the
    metrics' interpolation section, and the cycle is longer by the slower arc (its length
    π mm at 31.6 instead of 50 mm/s: 36 ms, to a sample)."""
    from feedtune.machine.run import run
    from feedtune.machine.spec import parse_machine

    axes = {name: {"plant": {"type": "software_servo", "technique": "sampled_data",
                             "time_constant": 0.02},
                   "tunables": {"position_gain": {"value": 20.0}}} for name in "xy"}
    base = {"name": "t", "axes": axes, "sampling_period": {"value": 1e-3}}
    path = parse_program("G21 G1 X10 F3000\nG3 X12 Y2 R2\nG1 Y12\n", source="t").path
    slow = run(parse_machine({**base, "interpolator": {"max_normal_acceleration": 0.5}}), path)
    fast = run(parse_machine(base), path)
    (arc,) = slow.metrics["interpolation"]["arcs_slowed"]
    assert arc["line"] == 2 and arc["radius"] == pytest.approx(0.002, abs=1e-12)
    extra = math.pi * 0.001 * (1 / math.sqrt(0.5 * 0.002) - 1 / 0.05)
    assert slow.metrics["cycle_time"] - fast.metrics["cycle_time"] == pytest.approx(extra, abs=1e-3)
@pytest.mark.parametrize("value", [1.0, 0.5, 0.3, 1.0 - 2**-52, 1e-3])
def test_vf_counters_without_recursion_are_the_recursion(value):
    """Error limit ≤ one pulse, no acceleration law: the counters are taken as the command
    (interpolate._vf_counters' induction) and equal, pulse for pulse, Tian's V-F recursion
    period by period (``feedtune.loops.pulse_train._track``) on commands that move at most
    one pulse a period: random walks with holds, reversals and runs of one pulse a period,
    three axes, starting away from zero."""
    from feedtune.loops.pulse_train import _track
    from feedtune.machine.interpolate import _vf_counters

    rng = np.random.default_rng(int(value * 1000))
    steps = rng.choice([-1, 0, 1], size=(20_000, 3), p=[0.3, 0.3, 0.4])
    steps[0] = 0  # from rest at 1234 pulses
    steps[5000:7000] = 1  # the fastest the generator follows
    command = 1234 + np.cumsum(steps, axis=0)
    fast = _vf_counters(command, value, None)
    for axis in range(3):
        pulses, _ = _track(command[:, axis] - command[0, axis], value, None)
        assert np.array_equal(fast[:, axis], command[0, axis] + np.cumsum(pulses))
    assert np.array_equal(fast, command)
