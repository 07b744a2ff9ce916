"""Robust tuning (issue 17 item 3) on the papers' drives: the constraints of a robust
design hold over the whole uncertainty as the independent validator re-measures it on a
dense grid, while the design tuned for the nominal plant alone breaks them there.

* Bhatia 1971 (Ch. IV; examples/bhatia-1971-robust-inertia.json): his rotary
  electro-hydraulic drive and specification, C_v ≥ 80 1/s, |G K'_v K'_p| ≥ 1000 1/s,
  M_peak ≤ 1.3, with the load inertia J_t ±30 % (ω_n and ξ follow it, App. A2).
* Koren 1979 (Figs 2 and 4, eqs 9 and 19): the software servo with τ anywhere in
  10-20 ms and a damping-ratio bound, reference-pulse (closed form) and sampled-data.

Tolerances: a robust design may exceed a bound by ROBUST_TOL (1e-6) of the bound, the
tuner's own feasibility tolerance; the validator's re-measurement differs from the
tuner's by at most its tolerance for the metric (1e-6 of the value for M_peak and ζ,
feedtune.validate.tolerances), so the grid is held to bound·(1 + 1e-6) + 1e-6·bound.
"""

from __future__ import annotations

import copy

import numpy as np
import pytest

from conftest import load_example, tune_dict
from feedtune.robust import ROBUST_TOL
from feedtune.validate import sampled_frequency
from feedtune.validate.models import model_for

#: the validator's tolerance for M_peak and ζ (feedtune.validate.tolerances.RULES), relative
VALIDATOR_REL = 1e-6
#: the dense grid over each range [points]: 1/120 of the range apart, 30× finer than the
#: robust search's 41-point grid is coarse
GRID = 241


def _peaks(result, inertias) -> np.ndarray:
    """The validator's M_peak of ``result``'s tuned design at each inertia [1]."""
    return np.array(list(_each_peak(result, inertias)))


def _each_peak(result, inertias):
    """:func:`_peaks` one inertia at a time, each computed as it is read: a test that
    asserts a bound is broken somewhere (``any``: the same as the max beyond the bound)
    stops at the first inertia that breaks it."""
    tuned = {name: t.value for name, t in result.tuned.items()}
    plant = result.spec["plant"]
    return (model_for({**plant, "inertia": j}, tuned).m_peak() for j in inertias)


@pytest.fixture(scope="module")
def bhatia():
    """(robust result, nominal result, the inertia grid [kg·m²])."""
    spec = load_example("bhatia-1971-robust-inertia")
    robust = tune_dict(spec)
    nominal_spec = copy.deepcopy(spec)
    nominal_spec["plant"]["inertia"] = spec["plant"]["inertia"]["nominal"]
    nominal_spec.pop("robust")
    nominal = tune_dict(nominal_spec)
    j = spec["plant"]["inertia"]["nominal"]
    return robust, nominal, np.linspace(0.7 * j, 1.3 * j, GRID)


def test_bhatia_robust_design_holds_m_peak_over_the_inertia_range(bhatia):
    robust, _, inertias = bhatia
    assert robust.success, robust.message
    assert robust.robust.converged and robust.validation["ok"]
    peaks = _peaks(robust, inertias)
    assert peaks.max() <= 1.3 * (1 + ROBUST_TOL) + VALIDATOR_REL * 1.3
    # the bound is what limits it: the worst inertia is the heaviest, at 1.3 (1e-6: IPOPT's
    # feasibility and the validator's rounding, measured 3e-8)
    assert peaks.max() == pytest.approx(1.3, abs=1e-6)
    worst = robust.robust.worst_cases[2]
    assert worst.metric == "m_peak" and worst.satisfied
    assert worst.parameters["inertia"] == pytest.approx(inertias[-1], rel=1e-9)


def test_bhatia_nominal_design_breaks_m_peak_in_the_range(bhatia):
    """The design tuned for the nominal inertia has M_peak 1.3 there and 1.64 at +30 %
    (measured); asserted above 1.4, far beyond any tolerance."""
    _, nominal, inertias = bhatia
    assert nominal.success
    assert _peaks(nominal, inertias[GRID // 2:GRID // 2 + 1])[0] == pytest.approx(1.3, abs=1e-6)
    # from the heaviest inertia, where M_peak is largest
    assert any(peak > 1.4 for peak in _each_peak(nominal, inertias[::-1]))


def test_bhatia_robust_design_pays_in_bandwidth(bhatia):
    """Holding M_peak at the heavy end costs bandwidth at the nominal inertia: 590 rad/s
    instead of 690 (measured); the robust design's M_peak at the nominal inertia is below
    the bound."""
    robust, nominal, _ = bhatia
    assert robust.metrics["bandwidth"].value < nominal.metrics["bandwidth"].value
    assert robust.metrics["m_peak"].value < 1.3 - 0.01


# -- Koren's software servo, τ in 10-20 ms ---------------------------------------------------

TAUS = np.linspace(0.010, 0.020, GRID)


def _servo(technique: str, zeta_min: float, robust: bool) -> dict:
    plant = {"type": "software_servo", "technique": technique,
             "time_constant": {"min": 0.010, "max": 0.020} if robust else 0.015,
             "blu": 5e-6, "max_velocity": 0.04}
    tunables = {"position_gain": {"min": 1, "max": 200}}
    if technique == "sampled_data":
        tunables["sampling_period"] = {"value": 0.015625}  # Koren's 64 Hz
    return {"name": f"koren-{technique}-{'robust' if robust else 'nominal'}", "plant": plant,
            "tunables": tunables,
            "objective": [{"metric": "radial_error", "radius": 0.008, "feed": 0.04}],
            "constraints": [{"metric": "damping_ratio", "min": zeta_min}],
            "solver": {"multistart": 1}}


@pytest.fixture(scope="module")
def servo_tuned():
    """``servo_tuned(technique, robust)``: :func:`_servo` with ζ ≥ 0.7 tuned, once per
    module (two tests read the robust reference-pulse design). Read it, do not change it."""
    made = {}

    def get(technique: str, robust: bool):
        if (technique, robust) not in made:
            made[technique, robust] = tune_dict(_servo(technique, 0.7, robust))
        return made[technique, robust]

    return get


def _dampings(result, taus=TAUS):
    """The validator's ζ of the tuned design at each of ``taus`` (s = ln z/T when sampled,
    Koren eq 19), each computed as it is read."""
    tuned = {name: t.value for name, t in result.tuned.items()}
    plant = result.spec["plant"]
    return (model_for({**plant, "time_constant": tau}, tuned).equivalent_pair()[0]
            for tau in taus)


@pytest.mark.parametrize("technique", ["reference_pulse", "sampled_data"])
def test_servo_robust_design_holds_the_damping_ratio_over_tau(technique, servo_tuned):
    """ζ ≥ 0.7 for every τ in 10-20 ms on the robust design; the nominal design (τ = 15 ms)
    has ζ = 0.7 there and less at 20 ms (0.61 and 0.60, measured; asserted below 0.65)."""
    robust, nominal = servo_tuned(technique, True), servo_tuned(technique, False)
    assert robust.success and robust.robust.converged and robust.validation["ok"]
    assert min(_dampings(robust)) >= 0.7 * (1 - ROBUST_TOL) - VALIDATOR_REL * 0.7
    # from the slowest drive, where ζ is least (Koren eq 9)
    assert any(zeta < 0.65 for zeta in _dampings(nominal, TAUS[::-1]))


def test_reference_pulse_robust_gain_is_koren_eq_9_at_the_slowest_drive(servo_tuned):
    """Koren eq 9: ζ = 1/(2√(Kτ)) falls with τ, so ζ ≥ 0.7 for all τ ≤ 20 ms is
    K ≤ 1/(4·0.49·0.020) = 25.51 1/s; the radial error on the 8 mm circle wants a larger K
    (33.5 1/s at τ = 15 ms), so the bound is active (1e-6: IPOPT's feasibility)."""
    robust = servo_tuned("reference_pulse", True)
    assert robust.tuned["position_gain"].value == pytest.approx(1 / (4 * 0.49 * 0.020), rel=1e-6)


# -- the worst-case refinement: a worst case between the corners -----------------------------

#: Koren's sampled servo at 64 Hz, the largest C_v whose closed-loop bandwidth stays under
#: 30 rad/s (a structural mode above it) for every τ in 5-40 ms. At a fixed K the
#: bandwidth peaks inside the range (≈ 20 ms) and is lower at both ends, so the corners
#: alone (interior_samples 0) miss the worst case and the search must find it.
BANDWIDTH = {"name": "koren-bandwidth-robust",
             "plant": {"type": "software_servo", "technique": "sampled_data",
                       "time_constant": {"min": 0.005, "max": 0.040, "nominal": 0.03},
                       "blu": 5e-6, "max_velocity": 0.04},
             "tunables": {"position_gain": {"min": 1, "max": 200},
                          "sampling_period": {"value": 0.015625}},
             "objective": [{"metric": "velocity_constant", "goal": "maximize"}],
             "constraints": [{"metric": "bandwidth", "max": 30}],
             "robust": {"interior_samples": 0},
             "solver": {"multistart": 1}}


def _bandwidths(result, taus) -> np.ndarray:
    """The validator's −3 dB bandwidth of the sampled loop at each τ [rad/s]."""
    return np.array(list(_each_bandwidth(result, taus)))


def _each_bandwidth(result, taus):
    """:func:`_bandwidths` one τ at a time, each computed as it is read."""
    tuned = {name: t.value for name, t in result.tuned.items()}
    plant = result.spec["plant"]
    return (sampled_frequency.bandwidth(model_for({**plant, "time_constant": tau}, tuned))
            for tau in taus)


def test_the_refinement_adds_the_interior_worst_case_until_the_bound_holds_everywhere():
    """Round 1 holds the nominal τ and the corners; the search finds the bandwidth above
    30 rad/s near 20 ms, adds that τ, and the later rounds hold it: the validator's
    bandwidth on a dense grid of τ is within 30·(1 + 1e-6) + its own 1e-6 relative
    tolerance, and the bound is what limits C_v (the grid's peak within 1e-4 rad/s of 30:
    the grid's spacing of 0.15 ms misses the peak by (Δτ)²·|b''|/8 ≈ 1e-5 rad/s)."""
    result = tune_dict(copy.deepcopy(BANDWIDTH))
    assert result.success and result.robust.converged, result.message
    assert result.robust.rounds >= 2
    added = [s for s in result.robust.scenarios if s.origin == "worst_case"]
    assert added and all(0.005 < s.parameters["time_constant"] < 0.040 for s in added)
    bandwidths = _bandwidths(result, np.linspace(0.005, 0.040, GRID))
    assert bandwidths.max() <= 30 * (1 + ROBUST_TOL) + VALIDATOR_REL * 30
    assert bandwidths.max() == pytest.approx(30, abs=1e-4)
    assert result.validation["ok"]


def test_without_refinement_the_corners_design_breaks_the_bound_between_them():
    """One round (max_rounds 1): the design that holds 30 rad/s at the nominal τ and the
    corners exceeds it inside the range (30.4 rad/s measured near 19 ms; asserted above
    30.1), and the result says so: not converged, not a success, the worst case violated."""
    spec = copy.deepcopy(BANDWIDTH)
    spec["robust"]["max_rounds"] = 1
    result = tune_dict(spec)
    assert not result.success and not result.robust.converged
    assert not result.robust.worst_cases[0].satisfied
    assert any(b > 30.1 for b in _each_bandwidth(result, np.linspace(0.005, 0.040, GRID)))
