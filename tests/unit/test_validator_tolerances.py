"""Validation gaps are judged on physical scales (feedtune.validate.tolerances, issue 14):
rounding-sized radial errors are not alarms, a real disagreement still is, and every
judged metric declares its scale and why.

The servo below has its gain chosen so that |H(e^{jωT})| = 1 on a 5 mm circle at 6 m/min
(1 + 2 Re L = 0, near Koren's eq 35), as the tuner finds when it minimises that radial
error: what is left is rounding, of order 1e-16·r, and two correct computations of it
differ by per cents, as in the issue's 24 false alarms.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from scipy.optimize import brentq

from feedtune.batch.reports import row_ok
from feedtune.objectives import METRICS
from feedtune.validate import validate_result, warning_lines
from feedtune.validate.software_servo import ServoModel
from feedtune.validate.tolerances import RELATIVE, RULES, Context, judge, rule_key, scale_of

TAU, PERIOD, BLU, V_M = 0.02, 0.004, 1e-6, 0.25
RADIUS, FEED = 0.005, 0.1


def _excess(gain: float) -> float:
    """1 + 2 Re L(e^{jωT}), whose sign is that of 1 − |H|."""
    return 1 + 2 * ServoModel(gain, TAU, PERIOD).open_loop(FEED / RADIUS)[0].real


GAIN = brentq(_excess, 0.5 / (PERIOD + 2 * TAU), 2 / (PERIOD + 2 * TAU), xtol=1e-14)


def _result(radial_error: float) -> dict:
    model = ServoModel(GAIN, TAU, PERIOD, blu=BLU, max_velocity=V_M)
    poles = model.poles()
    return {
        "tuned": {"position_gain": {"value": GAIN}, "sampling_period": {"value": PERIOD}},
        "spec": {"plant": {"type": "software_servo", "technique": "sampled_data",
                           "time_constant": TAU, "blu": BLU, "max_velocity": V_M}},
        "metrics": {"radial_error": {"metric": "radial_error", "value": radial_error,
                                     "unit": "m", "options": {"radius": RADIUS, "feed": FEED}}},
        "stability": {"stable": True, "poles": [[p.real, p.imag] for p in poles]},
    }


def _exact() -> float:
    return ServoModel(GAIN, TAU, PERIOD, blu=BLU, max_velocity=V_M).radial_error(RADIUS, FEED)


def test_a_rounding_sized_radial_error_gap_is_no_alarm():
    """2e-15 m apart (the issue's "gap 8.2e-6 > 1e-6" on errors of 1e-15 m): the same circle
    to any machine; judged against BLU/1000."""
    exact = _exact()
    assert exact < 1e-15
    block = validate_result(_result(exact + 2e-15))
    [row] = [e for e in block["entries"] if e["metric"] == "radial_error"]
    assert block["ok"] is True and row["ok"]
    assert row["tolerance"] == pytest.approx(BLU / 1000) and row["basis"] == "BLU/1000"
    assert row["unit"] == "m" and row["gap"] == pytest.approx(2e-15, rel=1e-6)
    assert warning_lines(block) == []


def test_a_radial_error_off_by_a_hundredth_of_a_blu_is_caught():
    block = validate_result(_result(_exact() + BLU / 100))
    assert block["ok"] is False
    [line] = warning_lines(block)
    assert "m > tolerance 1e-09 m (BLU/1000)" in line


def test_without_a_blu_a_length_is_judged_on_the_radius():
    """Sato's servo has no BLU: 1e-6·r/1000 (5e-12 m on a 5 mm circle)."""
    row = judge({"metric": "radial_error", "options": {"radius": RADIUS, "feed": FEED},
                 "value": 2e-14, "unit": "m"}, 1e-14, Context())
    assert row["ok"] and row["tolerance"] == pytest.approx(1e-6 * RADIUS / 1000)
    assert row["basis"] == "1e-06·r/1000"
    assert not judge({"metric": "radial_error", "options": {"radius": RADIUS, "feed": FEED},
                      "value": 1e-11, "unit": "m"}, 1e-14, Context())["ok"]


def test_a_large_value_is_judged_relatively():
    """Where rel·|value| exceeds the scale, the relative part sets the tolerance."""
    row = judge({"metric": "radial_error", "options": {"radius": RADIUS, "feed": FEED},
                 "value": 1e-2 * (1 + 2e-6), "unit": "m"}, 1e-2, Context(blu=BLU))
    assert not row["ok"] and row["basis"] == "1e-06 × |value|"


def test_no_overshoot_is_not_compared_relatively():
    """Overshoot 0 against 1e-13 (a response that touches its final value): a fraction of
    the unit step, not of zero."""
    row = judge({"metric": "overshoot", "options": {}, "value": 0.0, "unit": "1"}, 1e-13,
                Context(time=0.01))
    assert row["ok"] and row["basis"] == "1e-06"


def test_an_infinite_value_has_no_gap():
    never = {"metric": "pulse_settling_time", "options": {}, "value": float("inf"), "unit": "s"}
    context = Context(period=1e-5, pulse=1e-3)
    assert judge(never, float("inf"), context)["ok"] and judge(never, float("inf"), context)["gap"] is None
    assert not judge(never, 0.02, context)["ok"]


@pytest.mark.parametrize("key", sorted(RULES))
def test_every_rule_names_a_metric_a_scale_and_a_reason(key):
    rule = RULES[key]
    metric = key.split("(")[0]
    assert metric in METRICS
    assert rule_key(metric, {"measure": key[len(metric) + 1:-1]} if "(" in key else {}) == key
    assert rule.rel > 0 and rule.why.strip()
    if rule.scale not in (RELATIVE, "criterion"):
        context = Context(blu=BLU, time=0.01, period=1e-5, pulse=1e-3)
        value, label = scale_of(rule.scale, metric, {"radius": RADIUS, "input": "step"}, context)
        assert value > 0 and label


def test_the_documented_table_is_the_declared_one():
    """docs/validation.md lists every rule with its relative tolerance and fraction."""
    doc = (Path(__file__).resolve().parents[2] / "docs" / "validation.md").read_text()
    cells = [re.split(r"(?<!\\)\|", line) for line in doc.splitlines() if line.startswith("| `")]
    rows = {c[1].strip(" `"): [x.strip() for x in c[2:5]] for c in cells}
    assert set(rows) == set(RULES)
    for key, rule in RULES.items():
        rel, _, fraction = rows[key]
        assert float(rel) == rule.rel
        assert fraction == "—" if rule.scale == RELATIVE else float(fraction) == rule.fraction


def test_tune_and_batch_judge_the_same_entries():
    """`feedtune tune` warns on exactly the entries `feedtune batch` fails a spec for: both
    read the ``ok`` that :func:`judge` set (warning_lines and the batch row's validation_ok)."""
    base = {"status": "optimal", "success": True, "constraints_satisfied": True,
            "message": "fine", "objective": 1.0}
    for reported, alarm in ((_exact() + 2e-15, False), (_exact() + BLU / 100, True)):
        block = validate_result(_result(reported))
        assert bool(warning_lines(block)) is alarm
        assert row_ok({**base, "validation_ok": block["ok"]}) is not alarm
