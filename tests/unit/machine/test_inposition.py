"""The in-position wait (feedtune/machine/inposition.py): each hold found from the sum of
the pieces' errors is the one a whole-program simulation shows, the shortest that works.

Tolerances: the holds are found from the pieces' errors summed, the check from one
simulation of the whole reference; both are the same linear recursion, equal to rounding
(≈1e-16 m on errors of ≤ 1 mm), and the tails are cut after the slowest mode has decayed
by 1e-9 (≤ 1e-12 m here). 1e-10 m is far above both and far below the bands (1–5 µm).
"""

from __future__ import annotations

import numpy as np
import pytest

from feedtune.machine.gcode import parse_program
from feedtune.machine.inposition import settled_reference
from feedtune.machine.interpolate import interpolate, join, stop_pieces
from feedtune.machine.paths import corner
from feedtune.machine.run import axis_models, nominal_setting, run
from feedtune.machine.simulate import simulate_independent
from feedtune.machine.spec import parse_machine

ROUNDING = 1e-10  # m
PROGRAM = """G21 G90 G61
G1 X5 Y0 F1200
G1 X5 Y3
G0 X0 Y0
G64 G1 X2 Y2 F600
G1 X4 Y1
"""


def machine(interpolator=None, gains=(60.0, 45.0)):
    """Koren's sampled-data drives, τ = 20 ms: K τ = 1.2 and 0.9, underdamped (their ramp
    responses overshoot at a stop)."""
    axes = {name: {"plant": {"type": "software_servo", "technique": "sampled_data",
                             "time_constant": 0.02},
                   "tunables": {"position_gain": {"value": k}}}
            for name, k in zip("xy", gains)}
    return parse_machine({"name": "t", "axes": axes, "sampling_period": {"value": 1e-3},
                          "interpolator": interpolator or {}})


def stops(path):
    return parse_program(PROGRAM, source="t").path if path is None else path


@pytest.mark.parametrize("ratio", [1, 2])
@pytest.mark.parametrize("band", [1e-6, 5e-6])
def test_each_hold_is_the_shortest_that_settles(ratio, band):
    """G61 (every block an exact stop), a rapid's ends and G64 blocks; interpolation period
    1 or 2 samples. Simulating the whole settled reference: from each stop's resume sample
    until the next piece starts, every axis' error is within the band; one interpolation
    period earlier it was not (or the hold is 0)."""
    spec = machine({"period": ratio * 1e-3} if ratio > 1 else None)
    path = parse_program(PROGRAM, source="t").path
    models = axis_models(spec, nominal_setting(spec))
    reference = settled_reference(models, path, band=band, ratio=ratio, period=ratio * 1e-3)
    fine = reference.resampled(ratio)
    actual = simulate_independent(models, fine.position[:, :2])
    error = np.abs(fine.position[:, :2] - actual).max(axis=1)
    entries = reference.summary["in_position"]
    assert [e["segment"] for e in entries] == [0, 1, 2, 4]
    assert sum(e["hold"] > 0 for e in entries) >= 3
    for entry, following in zip(entries, entries[1:] + [None]):
        arrive = round(entry["time"] / fine.period)
        resume = arrive + round(entry["hold"] / fine.period)
        end = len(fine.time) if following is None else round(following["time"] / fine.period)
        # the next piece's motion starts one sample after the resume sample
        held = slice(resume, resume + 1) if following else slice(resume, end)
        assert np.all(error[held] <= band + ROUNDING)
        np.testing.assert_array_equal(fine.position[arrive:resume + 1],
                                      np.repeat(fine.position[arrive:arrive + 1],
                                                resume - arrive + 1, axis=0))
        if entry["hold"] > 0:
            earlier = resume - ratio
            window = error[earlier:resume + 1] if following else error[earlier:end]
            # holding one interpolation period less, an axis is still outside the band
            # at or after that instant (while the reference holds)
            assert window.max() > band - ROUNDING
    # the last stop: settled to the end of the reference
    last = entries[-1]
    resume = round((last["time"] + last["hold"]) / fine.period)
    assert resume == len(fine.time) - 1


def test_without_holds_the_pieces_are_the_interpolated_motion():
    """join with zero holds puts the pieces end to end: the same points along the path as
    the one-piece interpolation, each stop reached at the first sample after its motion."""
    path = parse_program(PROGRAM, source="t").path
    pieces = stop_pieces(path, period=1e-3, max_acceleration=0.5)
    assert len(pieces) == 4
    joined = join(path, pieces, [0] * len(pieces))
    whole = interpolate(path, period=1e-3, max_acceleration=0.5)
    assert path.distance(joined.position).max() < 1e-12
    assert joined.arc_length[-1] == pytest.approx(whole.arc_length[-1], abs=1e-12)
    for piece in pieces:
        assert np.all(np.diff(piece.arc_length) >= 0)
        np.testing.assert_allclose(piece.position[0], path.segments[piece.segment[0]].start,
                                   atol=1e-12)
        np.testing.assert_allclose(piece.position[-1], path.segments[piece.segment[-1]].end,
                                   atol=1e-12)
    # each piece starts on the sample after the previous one ends: at most one sample later
    # per stop than the one-piece reference
    assert 0 <= len(joined.time) - len(whole.time) <= len(pieces)


def test_run_reports_the_waits_and_the_cycle_includes_them():
    """A corner with an exact stop: the stop's hold and the end's are in the metrics'
    interpolation section, the cycle time is the motion plus the holds (to a sample per
    stop: a piece starts on a sample), and the overshoot at the corner is reported."""
    path = corner(0.01, 0.0, feed=0.02, turn=np.pi / 2, exact_stop=True)
    waited = run(machine({"in_position": 1e-6}), path).metrics
    plain = run(machine(), path).metrics
    holds = waited["interpolation"]["in_position"]
    assert [h["segment"] for h in holds] == [0, 1]
    assert all(h["hold"] > 0 for h in holds)
    assert waited["cycle_time"] == pytest.approx(plain["cycle_time"] + sum(h["hold"] for h in holds),
                                                 abs=2e-3)  # two stops, a sample each
    assert "interpolation" not in plain
    overshoot = {s["segment"]: s["overshoot"] for s in waited["stops"]}
    assert overshoot[0] > 1e-6


def test_the_tuner_keeps_no_reference_across_gains_when_it_waits_in_position():
    """The holds follow from the loops, so the tuner's kept reference (MachineTuner.samples)
    must be the one of the setting's gains: at the same feed and period, gains 60/45 and
    30/30 1/s give the references that commanded_samples gives for each (a reference kept
    by feed and period alone would hand the second setting the first one's holds)."""
    from dataclasses import replace

    from feedtune.machine.run import commanded_samples, prepare_axes
    from feedtune.machine.tune import MachineTuner

    spec = machine({"in_position": 1e-6})
    path = stops(None)
    tuner = MachineTuner(spec, path)
    first = nominal_setting(spec)
    second = replace(first, values={"x": {**first.values["x"], "position_gain": 30.0},
                                    "y": {**first.values["y"], "position_gain": 30.0}})
    for setting in (first, second):
        axes = prepare_axes(spec, setting)
        kept = tuner.samples(setting, axes)
        fresh = commanded_samples(spec, path, setting, axes)
        assert len(kept[0]) == len(fresh[0])
        assert np.array_equal(kept[1], fresh[1])
    assert len(tuner.samples(first, prepare_axes(spec, first))[0]) != len(fresh[0])
