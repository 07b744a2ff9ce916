"""The showcase of issue 3: Bhatia's 1971 specification tuned by feedtune, checked with
python-control on the exported loop (examples/bhatia-1971-hydraulic.json).

Bhatia's spec (Ch. IV): velocity constant C_v ≥ 80 1/s, sensitivity |G(0)K'_vK'_p| ≥ 1000
1/s, M_peak ≤ 1.3, velocity and position loops both stable; feedtune maximises the
closed-loop bandwidth with K'_p, K'_v and both lag-lead compensators free. The example tunes
from its first start (Bhatia's own design), which reaches the optimum 689.774 rad/s (before
issue 15 it asked for 8 starts, five of which ended there); about 1.2 s.

Every check below rebuilds the loop from the tuned numbers with python-control alone
(Fig 33's block diagram: velocity loop K'_v·Gc_v·G closed by unity feedback, then
K'_p·Gc_p/s in the position loop), not with feedtune's polynomials.
"""

import math

import control
import numpy as np
import pytest
from scipy.optimize import brentq, minimize_scalar

from conftest import load_example, tune_dict

SPEC = load_example("bhatia-1971-hydraulic")
PLANT = SPEC["plant"]
#: Bhatia's hand design is the example's initial point
HAND = {name: t["initial"] for name, t in SPEC["tunables"].items()}
DENSE_POINTS = 400_001  # over 10 decades: 5.8e-5 apart in ω


@pytest.fixture(scope="module")
def showcase(tuned):
    """The bundled example tuned from one start (the session's ``tuned``: the same tuning
    test_linear_bhatia.py reads)."""
    spec = dict(SPEC, solver=dict(SPEC["solver"], multistart=1))
    return tuned(spec)


def _lag_lead(values, prefix):
    t1, t2, t12 = (values[f"{prefix}.{k}"] for k in ("tau1", "tau2", "tau12"))
    return control.tf([t1 * t2, t1 + t2, 1], [t1 * t2, t1 + t2 + t12, 1])


def velocity_per_volt():
    """G(s) = K_s (K_q/D_m)/((1 + τs)(s²/ω_n² + 2ξs/ω_n + 1)) [rad/(s·V)] from the spec."""
    wn, xi = PLANT["hydraulic_natural_frequency"], PLANT["hydraulic_damping"]
    gain = PLANT["torque_motor_gain"] * PLANT["flow_gain"] / PLANT["displacement"]
    return control.tf([gain], np.polymul([PLANT["torque_motor_time_constant"], 1],
                                          [1 / wn**2, 2 * xi / wn, 1]))


def control_loops(values):
    """(inner closed velocity loop, open position loop L, closed position loop T)."""
    inner = control.feedback(values["velocity_gain"] * _lag_lead(values, "velocity_compensator")
                             * velocity_per_volt(), 1)
    open_loop = (values["position_gain"] * _lag_lead(values, "position_compensator") * inner
                 * control.tf([1], [1, 0]))
    return inner, open_loop, control.feedback(open_loop, 1)


def dense_peak_and_bandwidth(closed):
    """M_peak and −3 dB bandwidth of ``closed`` on a dense log grid over 1e-4 … 1e6 rad/s,
    polished by bounded Brent (peak) and brentq (crossing)."""
    num, den = closed.num[0][0], closed.den[0][0]
    dc = abs(num[-1] / den[-1])

    def gain(omega):
        s = 1j * np.asarray(omega)
        return np.abs(np.polyval(num, s) / np.polyval(den, s)) / dc

    omega = np.geomspace(1e-4, 1e6, DENSE_POINTS)
    values = gain(omega)
    k = int(np.argmax(values))
    peak = -minimize_scalar(lambda u: -gain(math.exp(u)), method="bounded",
                            bounds=(math.log(omega[k - 1]), math.log(omega[k + 1])),
                            options={"xatol": 1e-12}).fun
    j = int(np.argmax(values < 1 / math.sqrt(2)))
    bandwidth = brentq(lambda w: gain(w) - 1 / math.sqrt(2), omega[j - 1], omega[j], xtol=1e-14)
    return max(peak, values[k]), bandwidth


def tuned_values(result):
    return {name: t.value for name, t in result.tuned.items()}


def test_showcase_is_solved_and_reports_every_constraint_met(showcase):
    assert showcase.success and showcase.status == "optimal", showcase.message
    assert all(c.satisfied for c in showcase.constraints)
    assert showcase.stability["stable"] and showcase.stability["inner_loop"]["stable"]


def test_showcase_meets_bhatias_spec_by_python_control(showcase):
    """Both loops stable (python-control's poles), C_v = lim s·L(s) ≥ 80, sensitivity ≥ 1000,
    M_peak ≤ 1.3. The peak is active at the optimum; feedtune's exchange step stops once
    the refined peak exceeds the bound by ≤ 1e-7 relative, the result counts a bound as met
    within 1e-6: the python-control M_peak is asserted ≤ 1.3·(1 + 1e-6)."""
    values = tuned_values(showcase)
    inner, open_loop, closed = control_loops(values)
    assert np.all(inner.poles().real < 0)
    assert np.all(closed.poles().real < 0)
    num, den = open_loop.num[0][0], open_loop.den[0][0]
    assert den[-1] == 0  # type 1: one integrator
    velocity_constant = num[-1] / den[-2]
    assert velocity_constant >= 80
    sensitivity = abs(control.dcgain(velocity_per_volt())) * values["velocity_gain"] * values["position_gain"]
    assert sensitivity >= 1000
    peak, _ = dense_peak_and_bandwidth(closed)
    assert peak <= 1.3 * (1 + 1e-6)
    assert peak == pytest.approx(1.3, rel=1e-6)  # the bound is what limits the bandwidth


def test_showcase_reported_metrics_agree_with_python_control(showcase):
    """The issue's criterion: reported M_peak and bandwidth within 0.1 % of a dense
    independent evaluation. Measured agreement is at rounding level; asserted 1e-8 (the
    dense reference's own polishing tolerance, with margin). Margins against
    control.stability_margins to 1e-9."""
    values = tuned_values(showcase)
    _, open_loop, closed = control_loops(values)
    peak, bandwidth = dense_peak_and_bandwidth(closed)
    assert showcase.metrics["m_peak"].value == pytest.approx(peak, rel=1e-8)
    assert showcase.metrics["bandwidth"].value == pytest.approx(bandwidth, rel=1e-8)
    gm, pm, _, _, wc, _ = control.stability_margins(open_loop)
    assert showcase.metrics["gain_margin"].value == pytest.approx(gm, rel=1e-9)
    assert showcase.metrics["phase_margin"].value == pytest.approx(pm, rel=1e-9)
    assert showcase.metrics["crossover_frequency"].value == pytest.approx(wc, rel=1e-9)


def test_showcase_beats_the_hand_design(showcase, tuned):
    """Bhatia's design (the example's initial point) evaluated by the same python-control
    model: 187.9 rad/s bandwidth and C_v 79.73 < 80, so it does not even meet his own spec
    (docs/errata.md). feedtune's design is feasible and at least 3× wider (measured
    690 rad/s); its step IAE is lower too (measured 0.0086 against 0.0135 rad·s)."""
    _, hand_open, hand_closed = control_loops(HAND)
    _, hand_bandwidth = dense_peak_and_bandwidth(hand_closed)
    assert hand_bandwidth == pytest.approx(187.9, rel=1e-3)
    hand_cv = hand_open.num[0][0][-1] / hand_open.den[0][0][-2]
    assert hand_cv < 80
    assert showcase.metrics["bandwidth"].value > 3 * hand_bandwidth
    hand_result = tuned(dict(SPEC, tunables={n: {"value": v} for n, v in HAND.items()}))
    assert showcase.metrics["iae"].value < hand_result.metrics["iae"].value


def test_showcase_reports_ramp_and_load_variants_in_radians(showcase):
    """Reported-only metrics appear for every choice of their options (a ramp input, the
    IAE measure of load rejection), with the rotary axis' units."""
    metrics = showcase.metrics
    ramp = [k for k, m in metrics.items() if m.metric == "iae" and m.options["input"] == "ramp"]
    assert len(ramp) == 1 and metrics[ramp[0]].value > 0
    assert metrics["iae"].unit == metrics[ramp[0]].unit == "rad·s"
    assert metrics["ise"].unit == "rad²·s"
    loads = {m.options["measure"]: m for m in metrics.values() if m.metric == "load_rejection"}
    assert set(loads) == {"peak", "iae"} and all(m.value > 0 for m in loads.values())
    assert loads["peak"].unit == "rad/(N·m)" and loads["iae"].unit == "rad·s/(N·m)"


def test_an_unstable_design_reports_no_metrics():
    """Bhatia's Fig 21 loop (K'_p = 80, K'_v = 30, no compensators) has two right-half-plane
    roots: the result says so, and withholds every metric (an unstable loop's IAE or
    M_peak would be numbers without meaning)."""
    plant = {k: v for k, v in PLANT.items() if not k.endswith("_compensator")}
    result = tune_dict({"name": "fig21", "plant": plant,
                        "tunables": {"position_gain": {"value": 80}, "velocity_gain": {"value": 30}},
                        "objective": [{"metric": "bandwidth", "goal": "maximize"}]})
    assert not result.success and not result.stability["stable"]
    assert result.metrics and all(m.value is None for m in result.metrics.values())
