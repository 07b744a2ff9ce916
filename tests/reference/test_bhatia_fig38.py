"""Bhatia 1971, §IV.H "Operation of the Designed System", Fig 38 "Study of System
Operation" (thesis p. 110): the profile machined by the x and y servos together.

What the text says the simulation must show, and what each test holds:

* "At point B … a smooth transition of direction which is characterized by an absence of
  a sharply defined corner at B": without the special code the table never reaches B and
  turns from θ₁ to θ₂ over many samples.
* "for all part drawings which call for 'sharp corners', the programmer has to insert a
  special code … which leads to an automatic retardation as the corner is approached …
  The execution of the next block is started from rest. The slight overshoot indicated in
  the figure occurs while the table seeks a null position at B": with the special code
  (an exact stop) and the control's in-position wait the table reaches B, overshoots it
  along block 1, settles, and block 2 starts from rest.
* "CC' … is actually of the order of .010" … the lengths of these 'compensatory' blocks
  will depend on the time constant associated with the least responsive slide", and the
  chart formula S = ∫₀^{4τ} (V_i + ΔV(1 − e^{−t/τ})) dt: each slide's transition length
  is his S with its own τ, and the block must be as long as the slowest slide's.

Tolerance scales: his pulse weight (digital feedback) is "of the order of .0002"" (§II,
p. 30): 5.08 µm is the in-position band and the smallest deviation called visible. The
machine samples every T = 1 ms; a length measured between two sample instants on a table
moving at ≤ 40 in/min is uncertain by V·T = 17 µm per end.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from feedtune.machine.interpolate import transition_length
from feedtune.machine.paths import INCH, bhatia_profile
from feedtune.machine.run import run
from feedtune.machine.spec import parse_machine

REPO = Path(__file__).resolve().parents[2]
PULSE = 0.0002 * INCH  # m, Bhatia's pulse weight
FAST, SLOW = 40 * INCH / 60, 2 * INCH / 60  # m/s
T = 1e-3  # s


def his_machine(**interpolator):
    """Bhatia's designed drive (examples/machine/bhatia-fig38.json) on both axes."""
    raw = json.loads((REPO / "examples" / "machine" / "bhatia-fig38.json").read_text())
    raw["interpolator"] = interpolator
    return parse_machine(raw)


def corner_b(path):
    return path.segments[1].end


def heading(points):
    d = np.diff(points[:, :2], axis=0)
    return np.arctan2(d[:, 1], d[:, 0]), np.hypot(d[:, 0], d[:, 1]) / T


def test_rounded_corner_at_b_without_the_special_code():
    """No exact stop at B: the table cuts inside the corner (more than a pulse from B at
    its nearest), the largest deviation near B is more than a pulse, and the heading of
    the table turns from θ₁ to θ₂ gradually: it takes over 10 samples (10 ms, of the order
    of the drive's ramp lag 1/C_v = 12.5 ms; 22 measured) to go from within 1 % of the
    turn of θ₁ to within 1 % of θ₂, where a sharp corner turns within one sample."""
    path = bhatia_profile()
    result = run(his_machine(in_position=PULSE), path)
    b = corner_b(path)
    assert np.min(np.linalg.norm(result.actual - b, axis=1)) > PULSE
    at_b = next(c for c in result.metrics["corners"] if c["segment"] == 2)
    assert at_b["max_contour_error"] > PULSE
    theta1, theta2 = math.atan(2.0), math.atan(0.5)
    angle, speed = heading(result.actual)
    cutting = (result.segment[1:] >= 1) & (result.segment[1:] <= 2) & (speed > 0.5 * FAST)
    turn = theta1 - theta2
    left = np.flatnonzero(cutting & (angle < theta1 - 0.01 * turn))[0]
    reached = np.flatnonzero(cutting & (angle <= theta2 + 0.01 * turn))[0]
    assert reached - left > 10


def test_overshoot_at_b_with_the_special_code():
    """Exact stop at B with the in-position wait (band: one pulse): the table passes B
    along block 1 (overshoot above a pulse) after the reference has arrived and before
    block 2 starts, comes back within a pulse of B on every axis, at rest (speed below 1 %
    of the 40 in/min feed; settling within a 5 µm band leaves ≈ band/τ_slow ≈ 0.04 mm/s),
    and block 2 starts there. Without the wait (the reference alone stops), block 2
    starts as the reference arrives and the table never gets within a pulse of B."""
    path = bhatia_profile(exact_stop_at_b=True)
    result = run(his_machine(in_position=PULSE), path)
    b = corner_b(path)
    t1 = (b - path.segments[1].start) / path.segments[1].length
    (stop,) = [s for s in result.metrics["interpolation"]["in_position"] if s["segment"] == 1]
    arrive = round(stop["time"] / T)
    resume = arrive + round(stop["hold"] / T)
    assert stop["hold"] > 0
    past = (result.actual - b) @ t1
    held = slice(arrive, resume + 1)
    assert np.max(past[held]) > PULSE  # the overshoot, while the reference holds at B
    assert np.argmax(past[held]) > 0  # after the reference arrived
    assert np.all(np.abs(result.actual[resume, :2] - b[:2]) <= PULSE)
    speed = np.linalg.norm(result.actual[resume + 1] - result.actual[resume]) / T
    assert speed < 0.01 * FAST
    assert np.all(result.commanded[held] == b)  # block 2 starts only after the hold
    assert result.commanded[resume + 1] @ t1 != b @ t1
    reported = next(s for s in result.metrics["stops"] if s["segment"] == 1)
    assert reported["overshoot"] == pytest.approx(np.max(past[held]), abs=1e-12)
    no_wait = run(his_machine(), path)
    assert np.min(np.linalg.norm(no_wait.actual - b, axis=1)) > PULSE


def transition(result, path, block: int, axis: int) -> float:
    """Path length [m] that axis ``axis`` needs, from the sample where the reference enters
    block ``block`` with its new feed, to complete its speed change within e⁻⁴ of ΔV
    (Bhatia's 4τ): the axis' travel divided by its direction cosine. Blocks ``block`` and
    ``block`` + 1 (CC' and block 3) are collinear at the same feed; the search ends where
    the reference leaves them."""
    seg_before, seg_after = path.segments[block - 1], path.segments[block]
    cosine = (seg_after.end - seg_after.start)[axis] / seg_after.length
    v1, v2 = seg_before.feed * cosine, seg_after.feed * cosine
    start = int(np.flatnonzero(result.segment >= block)[0]) - 1
    stop = int(np.flatnonzero(result.segment >= block + 2)[0])
    velocity = np.diff(result.actual[:stop, axis]) / T
    outside = np.flatnonzero(np.abs(velocity[start:] - v2) > math.exp(-4) * abs(v2 - v1))
    done = start + int(outside[-1]) + 1
    return (result.actual[done, axis] - result.actual[start, axis]) / cosine


def first_order_machine(gains):
    """Koren's reference-pulse servo K/(s(1 + τs)) with τ = 0.1 ms: a first-order slide of
    time constant 1/K (and ramp lag 1/C_v = 1/K) to within Kτ ≤ 0.4 %."""
    axes = {name: {"plant": {"type": "software_servo", "technique": "reference_pulse",
                             "time_constant": 1e-4},
                   "tunables": {"position_gain": {"value": k}}}
            for name, k in zip("xy", gains)}
    return parse_machine({"name": "first-order", "axes": axes, "sampling_period": {"value": T},
                          "path": {"type": "bhatia_fig38"}})


def test_deceleration_block_follows_from_the_least_responsive_slide():
    """Fig 38's CC' (40 → 2 in/min) on first-order slides of K_x = 20 and K_y = 40 1/s:
    each slide's measured transition length is Bhatia's S with its own τ = 1/K, to within
    two sample travels (2·V·T = 34 µm: the feed change and the end of the transition
    each fall between samples) plus the slides' departure from first order (Kτ ≤ 0.4 %
    of S); the table has finished the feed change only when the slower (x) slide has,
    so the block needs the slowest slide's S, which the profile made with τ = 1/20 s is."""
    tau_slow = 1 / 20
    path = bhatia_profile(time_constant=tau_slow)
    result = run(first_order_machine((20.0, 40.0)), path)
    measured = [transition(result, path, 3, axis) for axis in (0, 1)]
    for s, k in zip(measured, (20.0, 40.0)):
        expected = float(transition_length(FAST, SLOW, 1 / k))
        assert s == pytest.approx(expected, abs=2 * FAST * T + 0.004 * expected)
    assert measured[0] == max(measured)
    assert path.segments[3].length == pytest.approx(
        float(transition_length(FAST, SLOW, tau_slow)), abs=1e-15)
    assert measured[0] == pytest.approx(path.segments[3].length,
                                        abs=2 * FAST * T + 0.004 * measured[0])


def test_his_deceleration_block_is_of_the_order_of_ten_thousandths():
    """Bhatia's designed drive on both axes: CC' "is actually of the order of .010"": the
    measured transition of each slide rounds to .01" at one significant figure (between
    .005" and .015"), as does his chart formula with the drive's ramp lag 1/C_v."""
    path = bhatia_profile()
    result = run(his_machine(), path)
    for axis in (0, 1):
        s = transition(result, path, 3, axis) / INCH
        assert 0.005 <= s < 0.015
    lag = result.metrics["slowest_axis_lag"]
    assert 0.005 <= float(transition_length(FAST, SLOW, lag)) / INCH < 0.015
