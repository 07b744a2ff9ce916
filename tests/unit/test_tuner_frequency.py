"""The tuner on peak and crossing constraints: grid rows, exchange points, exact answers.

One free gain K'_p on Bhatia's uncompensated hydraulic drive (K'_v fixed low enough for
a stable velocity loop): bandwidth and M_peak both grow with K'_p, so "widest bandwidth
with M_peak ≤ c" is solved exactly where the true (refined) peak equals c, and "least
M_peak with bandwidth ≥ b" where the true crossing equals b. The grid rows alone stop
where the grid's peak equals c, above the true optimum; the exchange step must add the
refined peak's frequency (asserted: at least one point added) until the true peak holds.
Every answer is checked by a dense numpy evaluation independent of feedtune's CasADi code.
"""

import copy
import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq, minimize_scalar

from feedtune.plants import plant_for
from feedtune.problem import tune
from feedtune.schema.spec import parse_spec

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "bhatia-1971-hydraulic.json"
PLANT = {k: v for k, v in json.loads(EXAMPLE.read_text())["plant"].items()
         if not k.endswith("_compensator")}


def spec(velocity_gain, objective, constraint):
    return {"name": "exchange", "plant": copy.deepcopy(PLANT),
            "tunables": {"velocity_gain": {"value": velocity_gain},
                         "position_gain": {"min": 1, "max": 1000, "initial": 5}},
            "objective": [objective], "constraints": [constraint], "solver": {"multistart": 1}}


def dense(result):
    """(M_peak, bandwidth) of the tuned loop from its numeric polynomials, on 2·10⁵ points
    per the loop's band, polished by bounded Brent and brentq."""
    parsed = parse_spec(result.spec)
    plant = plant_for(parsed.plant)
    values = {name: t.value for name, t in result.tuned.items()}
    loop = plant.loop(values, {n: (t.min, t.max) for n, t in plant.tunables().items()})
    num, den = loop.numeric_transfer()

    def gain(omega):
        s = 1j * np.asarray(omega)
        return np.abs(np.polyval(num, s) / np.polyval(den, s)) / abs(num[-1] / den[-1])

    omega = np.geomspace(*loop.frequency_band, 200_001)
    values = gain(omega)
    k = int(np.argmax(values))
    peak = max(values[k], 1.0)
    if 0 < k < len(omega) - 1:
        peak = max(peak, -minimize_scalar(lambda u: -gain(math.exp(u)), method="bounded",
                                          bounds=(math.log(omega[k - 1]), math.log(omega[k + 1])),
                                          options={"xatol": 1e-12}).fun)
    j = int(np.argmax(values < 1 / math.sqrt(2)))
    return peak, brentq(lambda w: gain(w) - 1 / math.sqrt(2), omega[j - 1], omega[j], xtol=1e-13)


@pytest.mark.parametrize("velocity_gain, bound", [(0.05, 1.1), (0.1, 1.3), (0.2, 1.05)])
def test_widest_bandwidth_under_a_peak_bound_is_exact(velocity_gain, bound):
    """The bound is met by the true peak and is active: measured within 3.1e-8 above c
    (EXCHANGE_TOL is 1e-7, the result's feasibility tolerance 1e-6, asserted); the reported
    values equal the dense ones to 1e-9 (the dense polish's tolerance)."""
    result = tune(parse_spec(spec(velocity_gain, {"metric": "bandwidth", "goal": "maximize"},
                                  {"metric": "m_peak", "max": bound})))
    assert result.success, result.message
    assert result.solver.starts[0].exchange_points >= 1
    peak, bandwidth = dense(result)
    assert bound * (1 - 1e-6) <= peak <= bound * (1 + 1e-6)
    assert result.metrics["m_peak"].value == pytest.approx(peak, rel=1e-9)
    assert result.metrics["bandwidth"].value == pytest.approx(bandwidth, rel=1e-9)
    assert result.objective == pytest.approx(-bandwidth, rel=1e-9)


@pytest.mark.parametrize("velocity_gain, bandwidth_min", [(0.1, 36.64), (0.1, 31.89)])
def test_least_peak_over_a_bandwidth_bound_is_exact(velocity_gain, bandwidth_min):
    """Epigraph on the peak, crossing variable bounded below: the bandwidth bound is
    active (the true crossing within 1e-6 of it) and the reported M_peak is the dense one."""
    result = tune(parse_spec(spec(velocity_gain, {"metric": "m_peak"},
                                  {"metric": "bandwidth", "min": bandwidth_min})))
    assert result.success, result.message
    peak, bandwidth = dense(result)
    assert bandwidth == pytest.approx(bandwidth_min, rel=1e-6)
    assert bandwidth >= bandwidth_min * (1 - 1e-6)
    assert result.metrics["m_peak"].value == pytest.approx(peak, rel=1e-9)
    assert result.objective == pytest.approx(peak, rel=1e-9)


def test_an_unstable_start_is_moved_to_a_stable_one():
    """K'_p = 900 makes the position loop unstable (K'_v = 0.05); restoration moves the start
    to the nearest stable gain, from where the optimum is the one found from a stable start."""
    from_unstable = spec(0.05, {"metric": "bandwidth", "goal": "maximize"},
                         {"metric": "m_peak", "max": 1.1})
    from_unstable["tunables"]["position_gain"]["initial"] = 900
    result = tune(parse_spec(from_unstable))
    reference = tune(parse_spec(spec(0.05, {"metric": "bandwidth", "goal": "maximize"},
                                     {"metric": "m_peak", "max": 1.1})))
    assert result.success and result.solver.iterations > 0, result.message
    assert result.tuned["position_gain"].value == pytest.approx(
        reference.tuned["position_gain"].value, rel=1e-6)


def test_a_start_no_gain_can_stabilise_is_not_solved_from():
    """With K'_v = 30 the velocity loop is unstable whatever K'_p is (Bhatia's Fig 21 data):
    restoration finds no stable point, IPOPT is not run from an unstable one."""
    result = tune(parse_spec(spec(30, {"metric": "bandwidth", "goal": "maximize"},
                                  {"metric": "m_peak", "max": 1.3})))
    start = result.solver.starts[0]
    assert not result.success and result.status == "infeasible"
    assert start.return_status == "No_Stable_Start" and start.iterations == 0
    assert not result.stability["inner_loop"]["stable"]
