"""Data-driven convex design (feedtune/measured/datadriven.py): the controller basis, the
Nyquist certificate against closed-loop roots, the metrics on data against closed forms,
the design against an analytic optimum, and robustness over several data sets."""

from __future__ import annotations

import math

import numpy as np
import pytest

from feedtune.measured.datadriven import (HALF_POWER, ControllerBasis, DataDrivenError,
                                          FrequencySet, design, interpolated_peak,
                                          nyquist_certificate, set_metrics)

#: Bhatia's rotary hydraulic drive, position per torque-motor volt (examples/
#: bhatia-1971-hydraulic.json: K_s K_q/D_m = 10 rad/(s·V), τ = 0.01 s, ω_n = 75 rad/s, ξ = 0.5)
GAIN, TAU, OMEGA_N, XI = 0.254 * 5.44225e-06 / 1.38233e-07, 0.01, 75.0, 0.5
OMEGA = np.logspace(-1, 4, 500)  # rad/s: 100 points a decade, as the bundled example


def hydraulic(omega, inertia=1.0):
    """G(jω) [rad/V] at J_t × ``inertia`` (ω_n ∝ J_t^-1/2, ξ ∝ J_t^1/2; App. A2)."""
    wn, xi = OMEGA_N / math.sqrt(inertia), XI * math.sqrt(inertia)
    s = 1j * np.asarray(omega)
    return GAIN / (s * (TAU * s + 1) * (s**2 / wn**2 + 2 * xi * s / wn + 1))


def hydraulic_den(inertia=1.0):
    wn, xi = OMEGA_N / math.sqrt(inertia), XI * math.sqrt(inertia)
    return np.polymul(np.polymul([TAU, 1], [1 / wn**2, 2 * xi / wn, 1]), [1, 0])


def closed_loop_stable(num_k, den_k, den_g) -> bool:
    """numpy roots of den_g·den_k + GAIN·num_k (the closed loop's characteristic polynomial)."""
    poly = np.polyadd(np.polymul(den_g, den_k), GAIN * np.asarray(num_k, dtype=float))
    return bool(np.all(np.roots(poly).real < 0))


def controller_polynomials(law, rho, tf=0.002):
    """K = num/den of ControllerBasis(law, tf) at ρ, highest power first."""
    kp, rest = rho[0], list(rho[1:])
    ki = rest.pop(0) if "i" in law else 0.0
    kd = rest.pop(0) if "d" in law else 0.0
    num = np.polyadd(np.polymul([kp], [tf, 1]) if "d" in law else [kp], [kd, 0] if "d" in law else [0])
    den = [tf, 1] if "d" in law else [1]
    if "i" in law:  # kp + ki/s + ...: multiply through by s
        num = np.polyadd(np.polymul(num, [1, 0]), np.polymul([ki], den))
        den = np.polymul(den, [1, 0])
    return num, den


# -- the controller -------------------------------------------------------------------------

def test_basis_is_the_pid_with_fixed_filter():
    basis = ControllerBasis("pid", 0.002)
    w = np.array([0.3, 30.0, 3000.0])
    s = 1j * w
    expected = 2.0 + 5.0 / s + 0.01 * s / (0.002 * s + 1)
    assert basis.names == ("kp", "ki", "kd")
    np.testing.assert_allclose(basis.response([2.0, 5.0, 0.01], w), expected, rtol=1e-14)
    assert ControllerBasis("pd", 0.001).names == ("kp", "kd")
    assert ControllerBasis("pi").integrators == 1 and ControllerBasis("p").integrators == 0


@pytest.mark.parametrize("law", ["p", "pi", "pd", "pid"])
def test_controller_polynomials_of_the_test_match_the_basis(law):
    """The helper that builds the characteristic polynomial below is the basis itself."""
    basis = ControllerBasis(law, 0.002 if "d" in law else None)
    rho = [2.0, 5.0, 0.01][:len(basis.names)]
    num, den = controller_polynomials(law, rho)
    np.testing.assert_allclose(np.polyval(num, 1j * OMEGA) / np.polyval(den, 1j * OMEGA),
                               basis.response(rho, OMEGA), rtol=1e-12)


# -- the Nyquist certificate ---------------------------------------------------------------

SWEEP = [("p", [g]) for g in (0.3, 1.0, 3.0, 6.0, 9.0, 12.0, 30.0)] + [
    ("pi", [2.0, 1.0]), ("pi", [2.0, 60.0]), ("pi", [0.5, 4.0]), ("pi", [8.0, 2.0]),
    ("pid", [2.0, 20.0, 0.07]), ("pid", [10.0, 5.0, 0.2]), ("pid", [1.0, 200.0, 0.01]),
    ("pd", [5.0, 0.1]), ("pd", [30.0, 0.01])]


@pytest.mark.parametrize("law,rho", SWEEP, ids=[f"{law}{rho}" for law, rho in SWEEP])
@pytest.mark.parametrize("inertia", [0.5, 1.0, 2.0])
def test_certificate_agrees_with_the_closed_loop_roots(law, rho, inertia):
    """Stable by the certificate exactly when numpy's roots of the characteristic polynomial
    are all in the left half-plane (the sweep crosses the stability boundary of each law:
    P is stable to k_p ≈ 6.5 V/rad on the design load)."""
    basis = ControllerBasis(law, 0.002 if "d" in law else None)
    data = FrequencySet("set", OMEGA, hydraulic(OMEGA, inertia))
    certificate = nyquist_certificate(data, lambda w: basis.response(rho, w), 1,
                                      basis.integrators, 0)
    num, den = controller_polynomials(law, rho)
    stable = closed_loop_stable(num, den, hydraulic_den(inertia))
    if not certificate.stable and certificate.unstable_closed_loop_poles is None:
        # no verdict is only allowed where 1 + L passes −1 between two measured points: a
        # closed-loop pole within 0.05 of the jω axis in damping (3°)
        poles = np.roots(np.polyadd(np.polymul(hydraulic_den(inertia), den), GAIN * num))
        assert "too sparse" in certificate.reason
        assert np.min(np.abs(poles.real) / np.abs(poles)) < 0.05, certificate.reason
        return
    assert certificate.stable == stable, certificate.reason


def test_the_sweep_holds_stable_and_unstable_loops():
    """The previous test cannot pass by always saying one thing."""
    verdicts = set()
    for law, rho in SWEEP:
        num, den = controller_polynomials(law, rho)
        verdicts.add(closed_loop_stable(num, den, hydraulic_den()))
    assert verdicts == {True, False}


def test_an_unstable_plant_is_counted_when_declared():
    """G = 1/(s − 1): k_p = 2 gives (s + 1)/(s − 1), stable; k_p = 0.5 leaves a pole at 0.5.
    Declared with no unstable pole, the stable loop is refused (the count differs by 2π)."""
    w = np.logspace(-2, 3, 400)
    data = FrequencySet("unstable", w, 1.0 / (1j * w - 1.0))
    basis = ControllerBasis("p")
    good = nyquist_certificate(data, lambda x: basis.response([2.0], x), 0, 0, 1)
    bad = nyquist_certificate(data, lambda x: basis.response([0.5], x), 0, 0, 1)
    undeclared = nyquist_certificate(data, lambda x: basis.response([2.0], x), 0, 0, 0)
    assert good.stable and good.phase_change == pytest.approx(math.pi, abs=1e-12)
    assert not bad.stable and bad.unstable_closed_loop_poles == 1
    assert not undeclared.stable


def test_sparse_or_short_data_is_not_certified():
    """Too few points to follow the phase, or a band that stops before the loop rolls off:
    no verdict is claimed, and the reason says which."""
    basis = ControllerBasis("p")
    sparse = np.logspace(-1, 4, 12)
    certificate = nyquist_certificate(FrequencySet("sparse", sparse, hydraulic(sparse)),
                                      lambda w: basis.response([3.0], w), 1, 0, 0)
    assert not certificate.stable and "too sparse" in certificate.reason
    short = np.logspace(-1, 1, 200)
    certificate = nyquist_certificate(FrequencySet("short", short, hydraulic(short)),
                                      lambda w: basis.response([3.0], w), 1, 0, 0)
    assert not certificate.stable and "highest measured frequency" in certificate.reason


# -- metrics on data -----------------------------------------------------------------------

def test_metrics_of_an_integrator_loop_are_its_closed_forms():
    """L = k/s: T = k/(s + k), so ω_b = ω_c = k, the phase margin 90° and |T| ≤ 1. The
    crossings are interpolated log-log between points 1/100 decade apart, where ln|T| and
    ln|L| are smooth: the error is O(h²) with h = ln 10/100, ≈ 1e-4 relative at most."""
    k = 37.0
    w = np.logspace(-1, 4, 501)
    data = FrequencySet("integrator", w, 1.0 / (1j * w))
    metrics = set_metrics(data, k / (1j * w))
    assert metrics["bandwidth"] == pytest.approx(k, rel=1e-4)
    assert metrics["crossover_frequency"] == pytest.approx(k, rel=1e-4)
    assert metrics["phase_margin"] == pytest.approx(90.0, abs=1e-9)
    assert metrics["m_peak"] <= 1.0
    assert HALF_POWER == pytest.approx(1 / math.sqrt(2))


def test_interpolated_peak_is_exact_on_a_parabola_in_log_frequency():
    """The vertex of a parabola in ln ω is found between the points to rounding."""
    w = np.logspace(0, 1, 17)
    value = 1.3 - 0.2 * (np.log(w) - math.log(3.3)) ** 2
    assert value.max() < 1.3 - 1e-4  # the peak lies between points
    assert interpolated_peak(w, value) == pytest.approx(1.3, abs=1e-12)


# -- the design ----------------------------------------------------------------------------

def test_p_design_reaches_the_analytic_optimum():
    """L = k/(s(τs + 1)): T is second order with ζ = 1/(2√(kτ)), M_r = 1/(2ζ√(1 − ζ²)), and
    the bandwidth grows with k, so the widest bandwidth at M_peak ≤ 1.3 is at M_r = 1.3:
    kτ = 1/(4ζ²) with ζ = 0.4335. The design holds the bound on the measured points and
    their parabolic peak with a margin of 3e-4 (GRID_MARGIN), which moves k by less than
    2e-3 (dM_r/M_r ≈ 0.6 dk/k here)."""
    tau = 0.01
    zeta = math.sqrt((1 - math.sqrt(1 - 1 / 1.3**2)) / 2)  # the smaller root of M_r = 1.3
    k_best = 1 / (4 * zeta**2 * tau)
    w = np.logspace(-1, 4, 500)
    data = FrequencySet("first-order", w, 1.0 / (1j * w * (tau * 1j * w + 1)))
    found = design([data], ControllerBasis("p"), {"kp": (1e-3, 1e4)}, {"kp": 1.0},
                   m_peak=1.3, integrators=1)
    assert found.status == "optimal" and found.stable
    assert found.values["kp"] == pytest.approx(k_best, rel=2e-3)
    assert found.metrics["m_peak"] <= 1.3 * (1 + 1e-6)


@pytest.fixture(scope="module")
def three_loads():
    return [FrequencySet(name, OMEGA, hydraulic(OMEGA, inertia))
            for name, inertia in (("half", 0.5), ("design", 1.0), ("double", 2.0))]


BOX = {"kp": (1e-2, 1e2), "ki": (1e-3, 1e3), "kd": (1e-5, 1.0)}
INITIAL = {"kp": 0.1, "ki": 0.01, "kd": 1e-4}


def test_multi_set_design_holds_its_bounds_on_every_set_and_single_set_does_not(three_loads):
    """Why robust tuning matters: tuned on the design load alone, the PID's M_peak on the
    double load exceeds 1.3; tuned on all three, every set meets M_peak ≤ 1.3 and M_s ≤ 2
    (at the measured points and the parabolic peak between them) and is certified stable."""
    basis = ControllerBasis("pid", 0.002)
    robust = design(three_loads, basis, BOX, INITIAL, m_peak=1.3, sensitivity_peak=2.0,
                    integrators=1)
    assert robust.status == "optimal" and robust.stable
    for per_set in robust.per_set:
        assert per_set["m_peak"] <= 1.3 * (1 + 1e-6)
        assert per_set["sensitivity_peak"] <= 2.0 * (1 + 1e-6)

    single = design([three_loads[1]], basis, BOX, INITIAL, m_peak=1.3, sensitivity_peak=2.0,
                    integrators=1)
    assert single.status == "optimal" and single.stable
    rho = np.array([single.values[n] for n in basis.names])
    double = three_loads[2]
    loop = double.response * basis.response(rho, double.omega)
    on_double = set_metrics(double, loop)
    assert on_double["m_peak"] > 1.3 * 1.01 or on_double["sensitivity_peak"] > 2.0 * 1.01
    # and the single-set design is the wider one: robustness costs bandwidth
    assert single.metrics["bandwidth"] > robust.metrics["bandwidth"]


def test_no_stabilising_start_is_an_error_naming_the_tunables():
    """A plant with an unstable pole that the data's controller cannot stabilise: P control of
    1/(s − 1) needs k_p > 1, and the box allows at most 0.5."""
    w = np.logspace(-2, 3, 300)
    data = FrequencySet("unstable", w, 1.0 / (1j * w - 1.0))
    with pytest.raises(DataDrivenError) as caught:
        design([data], ControllerBasis("p"), {"kp": (0.01, 0.5)}, {"kp": 0.5},
               m_peak=1.3, unstable_poles=1)
    assert caught.value.pointer == "/tunables"
