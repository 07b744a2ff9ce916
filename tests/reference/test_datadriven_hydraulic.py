"""Issue 17's check of the data-driven design: frequency data sampled from Bhatia's
hydraulic drive give at least 95 % of the model-based design's bandwidth at the same
M_peak, and the data-driven M_peak re-measured on a dense model evaluation is within the
bound.

The model-based design is feedtune's NLP (IPOPT) on the same drive as a ``linear`` plant
with a PID whose derivative filter ratio N is free; the data-driven PID has its filter
τ_f = T_d/N fixed (what keeps it convex) at the model optimum's, so the model optimum is
in its family and the comparison is of the two methods, not of two controller structures.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

import feedtune
from feedtune.measured.datadriven import ControllerBasis, FrequencySet, design

# Bhatia 1971 App. A2/A3 as examples/bhatia-1971-hydraulic.json gives it: K_s K_q/D_m =
# 0.254 m/V · 5.44225e-6 m²/s / 1.38233e-7 m³/rad = 10.0 rad/(s·V); τ = 0.01 s (errata);
# ω_n = 75 rad/s, ξ = 0.5
GAIN = 0.254 * 5.44225e-06 / 1.38233e-07
DENOMINATOR = np.polymul(np.polymul([0.01, 1.0], [1 / 75.0**2, 2 * 0.5 / 75.0, 1.0]), [1.0, 0.0])
M_PEAK = 1.3


def plant(omega):
    return GAIN / np.polyval(DENOMINATOR, 1j * np.asarray(omega))


@pytest.fixture(scope="module")
def model_based():
    """feedtune's NLP on the model: the widest bandwidth with M_peak ≤ 1.3."""
    result = feedtune.tune({
        "name": "bhatia-hydraulic-pid-model",
        "plant": {"type": "linear", "model": {"type": "transfer_function",
                                              "numerator": [GAIN],
                                              "denominator": [float(c) for c in DENOMINATOR]},
                  "input_unit": "V", "output_unit": "rad", "position_controller": "pid"},
        "tunables": {"position_controller.kp": {"min": 0.01, "max": 100, "initial": 1},
                     "position_controller.ti": {"min": 1e-3, "max": 10, "initial": 1},
                     "position_controller.td": {"min": 1e-4, "max": 1, "initial": 0.01},
                     "position_controller.n": {"min": 2, "max": 20, "initial": 10}},
        "objective": [{"metric": "bandwidth", "goal": "maximize"}],
        "constraints": [{"metric": "m_peak", "max": M_PEAK}],
        "solver": {"multistart": 2}})
    assert result.success, result.message
    return result


@pytest.fixture(scope="module")
def data_driven(model_based):
    """The convex design on 500 samples of G(jω), 0.1–10⁴ rad/s, τ_f = the model's T_d/N."""
    values = model_based.values
    tau_f = values["position_controller.td"] / values["position_controller.n"]
    omega = np.logspace(-1, 4, 500)
    basis = ControllerBasis("pid", tau_f)
    found = design([FrequencySet("sampled", omega, plant(omega))], basis,
                   {"kp": (0.01, 100.0), "ki": (1e-3, 1e4), "kd": (1e-5, 10.0)},
                   {"kp": 0.1, "ki": 0.01, "kd": 1e-4}, m_peak=M_PEAK, integrators=1)
    assert found.status == "optimal" and found.stable, found.message
    return found, basis


def test_data_driven_reaches_95_percent_of_the_model_bandwidth(model_based, data_driven):
    found, _ = data_driven
    model_bandwidth = model_based.metrics["bandwidth"].value
    assert model_based.metrics["m_peak"].value <= M_PEAK * (1 + 1e-6)
    assert found.metrics["bandwidth"] >= 0.95 * model_bandwidth, (
        found.metrics["bandwidth"], model_bandwidth)


def test_data_driven_m_peak_on_a_dense_model_evaluation_is_within_the_bound(data_driven):
    """|T| of the model with the data-driven gains on 400 001 frequencies (4·10⁴ a decade),
    its largest point refined by Brent's method: at most M_peak. The design held the bound
    at the measured points and at the parabola between them with a margin (GRID_MARGIN,
    3e-4); without that refinement this drive's peak between points was 1.3004."""
    found, basis = data_driven
    rho = np.array([found.values[n] for n in basis.names])

    def gain(log_omega):
        omega = np.exp(log_omega)
        loop = plant(omega) * basis.response(rho, omega)
        return np.abs(loop / (1 + loop))

    dense = np.logspace(-1, 4, 400_001)
    values = gain(np.log(dense))
    i = int(values.argmax())
    refined = minimize_scalar(lambda x: -gain(np.array([x]))[0],
                              bounds=(math.log(dense[max(i - 1, 0)]), math.log(dense[i + 1])),
                              method="bounded", options={"xatol": 1e-10})
    peak = max(values.max(), -refined.fun)
    assert peak <= M_PEAK, peak
