"""The report draws the gain and phase margins on every linear loop (issue 16, item 6).

Every bundled example whose plant the validator models as a linear loop (continuous
linear, sampled linear, Koren's sampled-data and reference-pulse loops, Sato's servo,
Bhatia's hydraulic and Ward-Leonard cascades) and a discrete drive (README "Your own
drive": Koren's servo as its ZOH equivalent in z) is evaluated at its spec's initial point
(every tunable fixed: no solve), and its Bode figure is drawn. Its PM arrow must stand at a
gain crossover of the validator model's L (|L| = 1) and its GM arrow at a phase crossover
(L real and negative), whenever the model's L has one: found here on a dense scan of its
own, 100 points per decade from 1e-4 rad/s to 1e8 rad/s (to π/T for a sampled loop).
"""

from __future__ import annotations

import copy
import json
import math
from pathlib import Path

import numpy as np
import pytest
from matplotlib.figure import Figure

from feedtune.api import Result
from feedtune.report.figures import bode_figure, metric
from feedtune.validate.model import NotCovered
from feedtune.validate.models import model_for

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
DISCRETE = {
    "name": "discrete-koren", "plant": {
        "type": "linear", "implementation": "sampled", "input_unit": "m/s",
        "output_unit": "m", "model": {
            "type": "transfer_function", "period": 0.015625,
            "numerator": [0.004781667235432163, 0.0036896864868862234],
            "denominator": [1.0, -1.4578333617716144, 0.4578333617716144]}},
    "tunables": {"position_controller.kp": {"min": 1, "max": 200, "initial": 18}},
    "objective": [{"metric": "bandwidth", "goal": "maximize"}]}
SPECS = {p.name: json.loads(p.read_text()) for p in sorted(EXAMPLES.glob("*.json"))}
SPECS["discrete drive (README)"] = DISCRETE
#: |L| at the PM arrow: the reported crossover is the tuner's, located to 2^-32 of a grid
#: step; 1e-6 in ln|L| is far below any margin's meaning (a 1e-4 dB gain)
GAIN_TOL = 1e-6
#: arg L at the GM arrow, within this of −180° [deg] (Brent to 1e-12 in ln ω)
PHASE_TOL_DEG = 1e-6


def evaluated(spec: dict, tuned) -> tuple[dict, object]:
    """The result at the spec's initial point (every tunable fixed) and its validator
    model, or skip when the validator has no linear model of the plant. The result is the
    session's ``tuned`` one (tests/conftest.py), as ``feedtune.tune`` writes it: the same
    fixed specs are evaluated by tests/reference/test_export_control.py (the sampled user
    drive, ≈ 1 s) when they run in this process."""
    fixed = copy.deepcopy(spec)
    fixed["tunables"] = {name: {"value": t.get("initial", t.get("value", math.sqrt(
        t.get("min", 1.0) * t.get("max", 1.0))))} for name, t in spec["tunables"].items()}
    result = json.loads(Result(tuned(fixed)).to_json())
    tuned = {name: t["value"] for name, t in result["tuned"].items()}
    try:
        model = model_for(result["spec"]["plant"], tuned, result.get("stability"))
        model.frequency_response(np.array([1.0]))
    except NotCovered as exc:
        pytest.skip(f"not a linear loop: {exc}")
    return result, model


def phase_crossings(model) -> bool:
    """Whether the model's L crosses the negative real axis (own scan, module docstring)."""
    high = math.pi / model.period if model.sampled else 1e8
    omega = np.geomspace(1e-4, high, int(100 * math.log10(high / 1e-4)))
    loop = model.frequency_response(omega)[0]
    turns = np.sign(loop.imag[:-1]) != np.sign(loop.imag[1:])
    return bool(np.any(turns & (loop.real[:-1] < 0))) or bool(model.sampled
                                                               and loop[-1].real < 0)


@pytest.fixture
def without_layout(monkeypatch):
    """The Bode figures drawn without their final ``tight_layout``: it moves the axes on
    the canvas by measuring every text (≈ 0.17 s of CPU a figure, most of these tests'
    drawing), never the arrows' data coordinates, which are what these tests read. The
    report's laid-out figures are tests/unit/test_report.py's and the report commands'."""
    monkeypatch.setattr(Figure, "tight_layout", lambda self, *args, **kwargs: None)


def arrows(figure) -> dict[str, float]:
    """Label (GM, PM) → the ω [rad/s] of its arrow on a Bode figure."""
    return {text.get_text(): text.xy[0] for ax in figure.axes for text in ax.texts
            if text.get_text() in ("GM", "PM")}


@pytest.mark.parametrize("name", sorted(SPECS))
def test_bode_figure_marks_both_margins(name, tuned, without_layout):
    result, model = evaluated(SPECS[name], tuned)
    marked = arrows(bode_figure(model, result))
    assert metric(result, "phase_margin") is not None, "a linear loop reports its PM"
    assert "PM" in marked
    loop = complex(model.frequency_response(np.array([marked["PM"]]))[0][0])
    assert abs(math.log(abs(loop))) < GAIN_TOL
    if metric(result, "gain_margin") is None or not phase_crossings(model):
        assert "GM" not in marked  # no phase crossover: an infinite gain margin
        return
    assert "GM" in marked
    loop = complex(model.frequency_response(np.array([marked["GM"]]))[0][0])
    assert loop.real < 0
    assert abs(math.degrees(math.atan2(loop.imag, -loop.real))) < PHASE_TOL_DEG


def test_an_infinite_gain_margin_draws_no_arrow_and_says_so(tuned, without_layout):
    """Koren's reference-pulse loop K/(s(1 + sτ)) has no phase crossover: its gain margin
    is +∞ (the result's JSON "Infinity"), so the Bode figure carries no GM arrow and no GM
    line, and its note says ∞ (before: a line at −20·log10(1/|L|) of the band's top, −110 dB,
    labelled as a finite margin)."""
    result, model = evaluated(SPECS["koren-1979-reference-pulse.json"], tuned)
    assert metric(result, "gain_margin") == math.inf
    figure = bode_figure(model, result)
    assert "GM" not in arrows(figure) and "PM" in arrows(figure)
    notes = " ".join(text.get_text() for ax in figure.axes for text in ax.texts)
    assert "gain margin ∞" in notes
    magnitude = figure.axes[0]
    assert not [line for line in magnitude.get_lines() if line.get_color() == "C5"]
