"""Contour metrics (feedtune/machine/contour.py): the windowed nearest-segment distance is
Path.distance, corners and stops are found where the program has them."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from feedtune.machine.contour import contour_distance
from feedtune.machine.gcode import parse_program
from feedtune.machine.interpolate import transition_length
from feedtune.machine.path import SegmentTable
from feedtune.machine.run import builtin_path, run
from feedtune.machine.spec import parse_machine

REPO = Path(__file__).resolve().parents[3]
PROGRAM = """G21 G90
G1 X10 Y0 F3000
G1 X10 Y10
G3 X0 Y10 I-5 J0
G2 X-5 Y5 R5
G1 X0 Y1 F600
"""


def machine(**extra):
    axes = {name: {"plant": {"type": "software_servo", "technique": "sampled_data",
                             "time_constant": 0.02},
                   "tunables": {"position_gain": {"value": k}}}
            for name, k in zip("xy", (20.0, 28.0))}
    return parse_machine({"name": "t", "axes": axes, "sampling_period": {"value": 1e-3},
                          "interpolator": {"max_acceleration": 2.0}, **extra})


def test_windowed_distance_is_the_path_distance():
    """Every sample of a simulated program with lines, arcs by I/J and R and a feed drop,
    open (it does not come back within the lag of itself; a closed contour's overshoot past
    its end is measured against the last block, not the first: contour.py's docstring):
    the windowed distance equals Path.distance over all segments (the same formulas, so
    to rounding: 1e-15 m)."""
    path = parse_program(PROGRAM, source="t.ngc").path
    result = run(machine(), path)
    table = SegmentTable.of(path)
    size = np.linalg.norm(result.commanded - result.actual, axis=1)
    windowed, _ = contour_distance(table, result.actual, result.arc_length, 4 * size + 1e-12)
    assert np.max(np.abs(windowed - path.distance(result.actual))) < 1e-15


def test_corner_stop_and_feed_drop_are_reported():
    """The corners are the right angle at (10, 0) mm and the join of the R arc and the last
    line at (−5, 5) mm (the line, the I/J arc and the R arc join tangentially); the
    program's end is a stop; the feed drop
    from 50 to 10 mm/s gives one deceleration block whose estimate is Bhatia's block length
    with τ = 1/C_v of the slower axis (K_x = 20 1/s against K_y = 28)."""
    path = parse_program(PROGRAM, source="t.ngc").path
    metrics = run(machine(), path).metrics
    turns = [round(c["turn"], 6) for c in metrics["corners"]]
    assert [c["position"][:2] for c in metrics["corners"]] == [[0.01, 0.0], [-0.005, 0.005]]
    assert turns[0] == round(np.pi / 2, 6)
    assert metrics["max_contour_error"] == max(c["max_contour_error"]
                                               for c in metrics["corners"])
    assert [s["position"][:2] for s in metrics["stops"]] == [[0.0, 0.001]]
    (block,) = metrics["deceleration_blocks"]
    assert block["feed_before"] == 0.05 and abs(block["feed_after"] - 0.01) < 1e-15
    assert metrics["slowest_axis_lag"] == pytest.approx(1 / 20, rel=1e-12)  # C_v = K exactly
    assert block["estimate"] == pytest.approx(
        float(transition_length(0.05, 0.01, 1 / 20)), rel=1e-12)


def test_bhatia_fig38_corner_b_against_the_slow_blocks():
    """Bhatia 1971 ch. 5, Fig 38, his hydraulic drive (examples/bhatia-1971-hydraulic.json
    at its initial, his design's, constants) on both axes: the corner at B, where 40 in/min
    turns by 37°, is rounded by far more than the joins of the slow blocks 3–5 ("for blocks
    5, 6 … the feed rates are small and the change in directions not so drastic: deviations
    negligible"): over ten times each of them, and above his resolution of 0.0001 in."""
    example = json.loads((REPO / "examples" / "bhatia-1971-hydraulic.json").read_text())
    fixed = {k: {"value": v["initial"]} for k, v in example["tunables"].items()}
    spec = parse_machine({"name": "fig38", "sampling_period": {"value": 1e-3},
                          "axes": {a: {"plant": example["plant"], "tunables": fixed}
                                   for a in "xy"},
                          "path": {"type": "bhatia_fig38"}})
    corners = run(spec, builtin_path(spec.path)).metrics["corners"]
    at_b = next(c for c in corners if c["segment"] == 2)
    slow = [c for c in corners if c["segment"] >= 5]
    assert len(slow) == 2
    assert at_b["max_contour_error"] > 0.0001 * 0.0254
    assert all(at_b["max_contour_error"] > 10 * c["max_contour_error"] for c in slow)


@pytest.mark.parametrize("program, gains", [
    (PROGRAM, (20.0, 28.0)),
    ((REPO / "examples" / "machine" / "arch-pocket.ngc").read_text(), (20.0, 28.0)),
    ((REPO / "examples" / "machine" / "slot-30deg.ngc").read_text(), (40.0, 12.0)),
], ids=["lines-arcs-feed-drop", "arch-pocket", "slot-30deg"])
def test_largest_contour_error_by_bounds_is_the_full_maximum(program, gains):
    """What the tuner reads (``rms=False``: the largest error found by bounds, without
    measuring every sample) is, bit for bit, the largest of the per-sample windowed
    distances, at the same sample: the bounds only decide which samples are measured,
    each measured as contour_distance measures it. Programs with lines, arcs, corners and
    a rapid; a stiff and a soft axis so the worst sample lies at different places."""
    axes = {name: {"plant": {"type": "software_servo", "technique": "sampled_data",
                             "time_constant": 0.02},
                   "tunables": {"position_gain": {"value": k}}}
            for name, k in zip("xy", gains)}
    spec = parse_machine({"name": "t", "axes": axes, "sampling_period": {"value": 1e-3},
                          "interpolator": {"max_acceleration": 2.0}})
    path = parse_program(program, source="t.ngc").path
    full = run(spec, path, detail=False).metrics
    fast = run(spec, path, detail=False, rms=False)
    assert fast.contour_error is None and "rms_contour_error" not in fast.metrics
    assert fast.metrics["max_contour_error"] == full["max_contour_error"] > 1e-6
    assert fast.metrics["max_contour_error_at"] == full["max_contour_error_at"]


def test_stops_found_by_bisection_are_those_of_a_scan_of_every_sample():
    """Every exact stop of a G61 program with a rapid (11 stops) gets the overshoot that a
    scan of all samples gives (the definition: the first sample whose commanded arc length
    reaches the stop, the window of the slowest settling time after it), bit for bit: both
    read the same samples, so no tolerance."""
    program = "G21 G90 G61\nG1 X5 Y0 F1200\nG1 X5 Y3\nG1 X1 Y4\nG0 X0 Y0\n" + "".join(
        f"G1 X{x} Y{y}\n" for x, y in ((2, 1), (3, 3), (1, 2), (4, 0), (0, 1), (2, 2), (0, 0)))
    path = parse_program(program, source="t.ngc").path
    result = run(machine(), path)
    stops = result.metrics["stops"]
    table = SegmentTable.of(path)
    ends = table.begin + table.length
    slowest = result.metrics["slowest_axis_settling_time"]
    time, arc = result.time, result.arc_length
    scanned = []
    for i, seg in enumerate(path.segments):
        if not (i == len(path.segments) - 1 or seg.exact_stop or table.rapid[i]):
            continue
        k0 = int(np.flatnonzero(arc >= ends[i] - 1e-12)[0])
        window = (time >= time[k0]) & (time <= time[k0] + max(slowest, time[1] - time[0]))
        direction = seg.tangent_at(seg.length)[0]
        past = (result.actual[window] - table.end[i]) @ direction
        commanded = np.maximum(0.0, (result.commanded[window] - table.end[i]) @ direction)
        scanned.append((i, float(time[k0]), float(max(0.0, np.max(past - commanded)))))
    assert len(scanned) == 11
    assert [(s["segment"], s["time"], s["overshoot"]) for s in stops] == scanned
