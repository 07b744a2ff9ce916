"""The sensitivity peak M_s and the pole metrics (smallest damping, slowest decay rate)
against python-control, and tuned as constraints and objectives.

python-control is the independent check: on the tuned loop exported by
``feedtune.load_result(...).to_control()`` it computes the poles (``control.poles``), their
damping (``control.damp``, z-poles through ln(z)/dt as MATLAB does) and |S(jω)| of the
``error`` system S = 1 − T (``control.frequency_response``); each is compared with the
result's reported value. The tunings hold each new metric as a constraint on Bhatia's
hydraulic example and check that the result validates (feedtune.validate re-measures each
value from its own model).
"""

import copy
import json
import math

import control
import numpy as np
import pytest
from scipy.optimize import brentq, minimize_scalar

import feedtune
from conftest import TUNED, load_example, tune_dict
from discrete_checks import response
from feedtune_cli import run_cli

#: tuned values of bundled examples (the optimum `feedtune tune` finds for each, shared with
#: tests/reference/test_export_control.py in conftest.TUNED): evaluated, not solved
FIXED = {name: TUNED[name] for name in (
    "bhatia-1971-hydraulic", "ward-leonard-feed-drive", "koren-1979-sampled-data",
    "koren-1979-reference-pulse", "sato-finish", "sato-table2-a")}
#: examples whose continuous loop has an open loop L(jω) (M_s reported; the sampled-data
#: loops report it too, checked against python-control at z = e^{jωT} in
#: tests/unit/test_sampled_frequency.py): every continuous one since Koren's
#: reference-pulse loop has its K/(s(1 + sτ)) (issue 16); a loop without one (Tian's pulse
#: generator) is refused at the spec, tests/unit/test_pole_metrics.py
WITH_OPEN_LOOP = {"bhatia-1971-hydraulic", "ward-leonard-feed-drive", "sato-table2-a",
                  "koren-1979-reference-pulse"}
SAMPLED = {"koren-1979-sampled-data", "sato-finish"}


@pytest.fixture(scope="module")
def exported(tmp_path_factory, tuned):
    """name → (Result read from its file, ControlSystems) of FIXED's specs, each tuned by
    the session's ``tuned`` (test_export_control.py evaluates the same specs)."""
    directory = tmp_path_factory.mktemp("results")
    cache = {}

    def get(name):
        if name not in cache:
            spec = copy.deepcopy(load_example(name))
            spec["tunables"] = {k: {"value": v} for k, v in FIXED[name].items()}
            spec["solver"] = {"multistart": 1}
            path = directory / f"{name}.json"
            path.write_text(tuned(spec).model_dump_json())
            loaded = feedtune.load_result(path)
            cache[name] = loaded, loaded.to_control()
        return cache[name]

    return get


@pytest.mark.parametrize("name", sorted(FIXED))
def test_pole_metrics_agree_with_python_control(exported, name):
    """ζ_min = min of control.damp's ζ, σ_min = min −Re of control.poles (ln(z)/dt when
    discrete). Two eigenvalue computations of different matrices of one loop: rounding
    ~1e-12 of each pole's magnitude, so ζ (order 1) to 1e-8 and σ to 1e-8·|p| of the pole
    that sets it (Bhatia's poles span 1 to 5e5 rad/s)."""
    loaded, systems = exported(name)
    metrics = loaded.data.metrics
    closed = systems.closed_loop
    _, zeta, _ = control.damp(closed, doprint=False)
    poles = control.poles(closed).astype(complex)
    if closed.isdtime(strict=True):
        poles = np.log(poles[np.abs(poles) > 1e-12]) / closed.dt
    k = int(np.argmin(-poles.real))
    assert metrics["pole_damping"].value == pytest.approx(float(np.min(zeta)), abs=1e-8)
    assert abs(metrics["decay_rate"].value - float(-poles[k].real)) <= 1e-8 * abs(poles[k])
    assert metrics["decay_rate"].unit == "1/s" and metrics["pole_damping"].unit == "1"


DENSE = np.geomspace(1e-3, 1e7, 200_001)


@pytest.mark.parametrize("name", sorted(WITH_OPEN_LOOP))
def test_sensitivity_peak_agrees_with_python_control(exported, name):
    """M_s = max |S(jω)| of the exported ``error`` system S = 1 − T: python-control's
    frequency response on 10 decades (4.6e-5 apart in ln ω; ``response``,
    tests/discrete_checks.py: a state space's values as python-control's, solved in one
    stacked call), the largest sample polished by bounded Brent (xatol 1e-12 in ln ω);
    1e-8 relative: both locate the same smooth peak to far better than that."""
    loaded, systems = exported(name)
    error = systems.error
    mag = np.abs(response(error, 1j * DENSE))
    k = int(np.argmax(mag))
    assert 0 < k < len(DENSE) - 1, "the peak lies inside the grid"
    polished = minimize_scalar(lambda u: -float(np.abs(error(1j * math.exp(u)))),
                               method="bounded", options={"xatol": 1e-12},
                               bounds=(math.log(DENSE[k - 1]), math.log(DENSE[k + 1])))
    expected = max(mag[k], -polished.fun)
    assert loaded.data.metrics["sensitivity_peak"].value == pytest.approx(expected, rel=1e-8)
    # the validator measured it too, from its own model
    [entry] = [e for e in loaded.data.validation["entries"] if e["metric"] == "sensitivity_peak"]
    assert entry["ok"] and entry["gap"] <= 1e-9 * entry["validated"]


def test_every_fixed_example_is_classed():
    assert set(FIXED) == WITH_OPEN_LOOP | SAMPLED


# -- tuned as constraints on Bhatia's hydraulic example -----------------------------------------

def validated(result, metric: str) -> dict:
    [entry] = [e for e in result.validation["entries"] if e["metric"] == metric]
    return entry


def test_bhatia_with_a_sensitivity_peak_bound_validates():
    """The bundled spec (widest bandwidth; C_v ≥ 80, sensitivity ≥ 1000, M_peak ≤ 1.3)
    plus M_s ≤ 2: its optimum has M_s = 2.17 (README), so the bound is active; the tuned
    loop validates, and its bandwidth is below the unbounded optimum's 689.77 rad/s."""
    spec = load_example("bhatia-1971-hydraulic")
    spec["constraints"].append({"metric": "sensitivity_peak", "max": 2.0})
    result = tune_dict(spec)
    assert result.success, result.message
    assert result.validation["ok"], result.validation
    m_s = result.metrics["sensitivity_peak"].value
    # active: at its bound within IPOPT's tolerance (1e-6 relative, FEASIBILITY_TOL)
    assert m_s == pytest.approx(2.0, rel=1e-6)
    assert validated(result, "sensitivity_peak")["ok"]
    assert result.metrics["bandwidth"].value < 689.77


def test_bhatia_with_a_decay_rate_bound_validates():
    """The bundled spec, all eight tunables free, plus σ_min ≥ 12 1/s: its optimum has
    σ_min = 10.93 1/s (the slow real pole of the lag-leads), so the bound binds; measured
    684.2 rad/s in 114 IPOPT iterations."""
    spec = load_example("bhatia-1971-hydraulic")
    spec["constraints"].append({"metric": "decay_rate", "min": 12.0})
    result = tune_dict(spec)
    assert result.success, result.message
    assert result.validation["ok"], result.validation
    # active: at its bound within IPOPT's tolerance (1e-6 relative, FEASIBILITY_TOL)
    assert result.metrics["decay_rate"].value == pytest.approx(12.0, rel=1e-6)
    assert validated(result, "decay_rate")["ok"]
    assert result.metrics["m_peak"].value <= 1.3 * (1 + 1e-6)
    assert result.metrics["bandwidth"].value < 689.77


def bhatia_gains_only() -> dict:
    """Bhatia's spec with his compensators fixed at his hand design: the two gains free."""
    spec = load_example("bhatia-1971-hydraulic")
    for name, tunable in list(spec["tunables"].items()):
        if "compensator" in name:
            spec["tunables"][name] = {"value": tunable["initial"]}
    return spec


def test_bhatia_with_damping_and_decay_bounds_validates():
    """ζ_min ≥ 0.3 and σ_min ≥ 8 1/s with M_s ≤ 2 on Bhatia's gains: the unbounded optimum
    of this spec has ζ_min = 0.09 and σ_min = 7.6 1/s, so both pole bounds bind. The
    result holds every bound, validates, and python-control's poles of the tuned loop
    agree (1e-8, as above)."""
    spec = bhatia_gains_only()
    spec["constraints"] += [{"metric": "sensitivity_peak", "max": 2.0},
                            {"metric": "pole_damping", "min": 0.3},
                            {"metric": "decay_rate", "min": 8.0}]
    result = tune_dict(spec)
    assert result.success, result.message
    assert result.validation["ok"], result.validation
    assert all(c.satisfied for c in result.constraints)
    zeta = result.metrics["pole_damping"].value
    assert zeta == pytest.approx(0.3, rel=1e-6)  # the active one: the light pair at ζ = 0.3
    assert result.metrics["decay_rate"].value >= 8.0 * (1 - 1e-6)
    for metric in ("pole_damping", "decay_rate", "sensitivity_peak"):
        assert validated(result, metric)["ok"]
    poles = np.array([complex(re, im) for re, im in result.stability["poles"]])
    assert float(np.min(-poles.real / np.abs(poles))) == pytest.approx(zeta, abs=1e-8)


@pytest.mark.parametrize("order", [(1, 2, 0), (2, 1, 0)],
                         ids=["damping-decay-ms", "decay-damping-ms"])
def test_bhatia_gains_with_pole_bounds_in_another_order(order):
    """The case above with its three bounds listed in another order (so the NLP's rows and
    IPOPT's path differ): optimal at the same 86.1187 rad/s, which the Routh rows of
    main f27aa3f also reached in all three orders (1e-5 relative: its printed digits).
    The factor form's first attempt ends "infeasible" here (its roots kept in the
    factors they started in); the next attempt resumes from its end point with the
    factors of the poles there, and solves (measured: 522 and 118 iterations)."""
    spec = bhatia_gains_only()
    bounds = [{"metric": "sensitivity_peak", "max": 2.0}, {"metric": "pole_damping", "min": 0.3},
              {"metric": "decay_rate", "min": 8.0}]
    spec["constraints"] += [bounds[i] for i in order]
    result = tune_dict(spec)
    assert result.success and result.status == "optimal", result.message
    assert result.validation["ok"], result.validation
    assert result.metrics["pole_damping"].value == pytest.approx(0.3, rel=1e-6)
    assert result.metrics["bandwidth"].value == pytest.approx(86.1187, rel=1e-5)


def test_bhatia_eight_tunables_with_a_damping_bound_solves_from_the_cli(tmp_path):
    """The bundled spec, all eight tunables free, plus ζ_min ≥ 0.3 (his design: 0.134),
    through `feedtune tune`: optimal, validated, and at the optimum an independent solver
    finds. The reference is benchmarks/bhatia_damping_vs_scipy.py: SLSQP from 8 starts on
    that file's numpy model (no feedtune code, ζ_min from numpy.roots) reached 231.591
    rad/s; feedtune's 231.5914 is checked against 231.59 (the reference to its printed
    digits, 4e-6 relative, 4× feedtune's 1e-6 feasibility tolerance on M_peak ≤ 1.3). The
    poles of the exported loop (python-control) meet the bound to 1e-8 (the accuracy of two
    eigenvalue computations, as above). Before the factor form (issue 16) the Routh rows
    of p(e^{jα}s)p(e^{−jα}s) ended at IPOPT's iteration limit at 98.3 rad/s."""
    spec = load_example("bhatia-1971-hydraulic")
    spec["constraints"].append({"metric": "pole_damping", "min": 0.3})
    path, out = tmp_path / "spec.json", tmp_path / "result.json"
    path.write_text(json.dumps(spec))
    run = run_cli("tune", str(path), "-o", str(out), text=True)
    assert run.returncode == 0, run.stderr
    loaded = feedtune.load_result(out)
    result = loaded.data
    assert result.success and result.status == "optimal", result.message
    assert result.validation["ok"], result.validation
    assert validated(result, "pole_damping")["ok"]
    assert result.metrics["bandwidth"].value >= 231.59
    assert result.metrics["m_peak"].value <= 1.3 * (1 + 1e-6)
    _, zeta, _ = control.damp(loaded.to_control().closed_loop, doprint=False)
    assert float(np.min(zeta)) >= 0.3 - 1e-8
    assert result.metrics["pole_damping"].value == pytest.approx(float(np.min(zeta)), abs=1e-8)


def test_maximised_damping_of_bhatias_gains_reaches_the_tie():
    """Bhatia's two gains (his compensators fixed), ζ_min maximised: at the optimum K'_v
    is at its lower bound and two pole pairs have the same damping (0.46984), a corner of
    min(ζ) where no gradient vanishes. Reference: a search in ln K'_p on
    numpy.roots of the loop's characteristic polynomial (a CasADi function of the gains,
    evaluated numerically), polished by bounded Brent from the best of 400 log-spaced
    K'_p; 1e-6 relative: the region's rows keep a margin 1e-7 of their scale (measured
    2.5e-7 below the 2-D Nelder–Mead optimum). On main this ended in a LinAlgError."""
    spec = bhatia_gains_only()
    spec["objective"] = [{"metric": "pole_damping", "goal": "maximize"}]
    spec["constraints"] = []
    result = tune_dict(spec)
    assert result.success and result.solver.method == "ipopt", result.message
    assert validated(result, "pole_damping")["ok"]
    kv = result.tuned["velocity_gain"]
    assert kv.at_bound == "min"
    polynomial = gains_polynomial(spec, kv.value)

    def damping(log_kp):
        roots = np.roots(np.asarray(polynomial(math.exp(log_kp)), dtype=float).ravel())
        return float(np.min(-roots.real / np.abs(roots)))

    box = (math.log(10.0), math.log(1000.0))  # the spec's K'_p box
    grid = np.linspace(*box, 400)
    start = grid[int(np.argmax([damping(u) for u in grid]))]
    best = minimize_scalar(lambda u: -damping(u), method="bounded", options={"xatol": 1e-12},
                           bounds=(max(box[0], start - 0.02), min(box[1], start + 0.02)))
    zeta = result.metrics["pole_damping"].value
    assert zeta == pytest.approx(-best.fun, rel=1e-6)
    poles = np.array([complex(re, im) for re, im in result.stability["poles"]])
    ratios = np.sort(-poles.real / np.abs(poles))
    # two pairs (four poles) at the smallest damping: each pair's row keeps its own margin
    # (1e-7 of that row's scale), measured 2.9e-6 apart; elsewhere they differ by O(0.1)
    assert ratios[2] - ratios[0] <= 1e-5


def gains_polynomial(spec: dict, velocity_gain: float):
    """K'_p ↦ the closed loop's characteristic polynomial (highest power first) of Bhatia's
    plant, his compensators and this K'_v: the plant's loop with K'_p a CasADi symbol."""
    import casadi as ca

    from feedtune.plants import plant_for
    from feedtune.schema.spec import parse_spec

    parsed = parse_spec(spec)
    plant = plant_for(parsed.plant)
    box = {n: (t.min, t.max) for n, t in plant.tunables().items()}
    kp = ca.MX.sym("kp")
    values = {n: ca.MX(t.value) for n, t in parsed.tunables.items() if t.value is not None}
    values.update(position_gain=kp, velocity_gain=ca.MX(velocity_gain))
    loop = plant.loop(values, box)
    return ca.Function("p", [kp], [ca.vertcat(*loop.characteristic_polynomial)])


# -- closed forms through the NLP (IPOPT, not the scalar search) ---------------------------------

def reference_pulse(objective, constraints) -> dict:
    """Koren's reference-pulse loop, τ = 20 ms, K free; an IPOPT option so that the NLP's
    rows are what is solved (one free tunable would otherwise take the scalar search)."""
    return {"name": "closed-form",
            "plant": {"type": "software_servo", "technique": "reference_pulse",
                      "time_constant": 0.02},
            "tunables": {"position_gain": {"min": 1, "max": 200, "initial": 5}},
            "objective": objective, "constraints": constraints,
            "solver": {"multistart": 1, "ipopt_options": {"mu_strategy": "monotone"}}}


def test_maximised_decay_rate_is_one_over_two_tau():
    """s² + s/τ + K/τ: σ_min = (1 − √(1 − 4Kτ))/(2τ) rises to 1/(2τ) = 25 1/s at Kτ = 1/4
    and stays there (so the optimum is not unique in K)."""
    result = tune_dict(reference_pulse([{"metric": "decay_rate", "goal": "maximize"}], []))
    assert result.success and result.solver.method == "ipopt", result.message
    assert result.metrics["decay_rate"].value == pytest.approx(25.0, rel=1e-6)
    assert result.tuned["position_gain"].value >= 12.5 * (1 - 1e-6)


def test_decay_rate_bound_is_exact():
    """min C_v = K subject to σ_min ≥ 20 1/s: (1 − √(1 − 4Kτ))/(2τ) = 20 at K = 12 1/s."""
    result = tune_dict(reference_pulse([{"metric": "velocity_constant"}],
                                       [{"metric": "decay_rate", "min": 20.0}]))
    assert result.success and result.solver.method == "ipopt", result.message
    assert result.tuned["position_gain"].value == pytest.approx(12.0, rel=1e-6)


def test_damping_bound_is_exact():
    """max C_v = K subject to ζ_min ≥ 0.7: ζ = 1/(2√(Kτ)) = 0.7 at K = 1/(4·0.49·τ)."""
    result = tune_dict(reference_pulse([{"metric": "velocity_constant", "goal": "maximize"}],
                                       [{"metric": "pole_damping", "min": 0.7}]))
    assert result.success and result.solver.method == "ipopt", result.message
    assert result.tuned["position_gain"].value == pytest.approx(1 / (4 * 0.49 * 0.02), rel=1e-6)


def test_maximised_decay_rate_of_a_sampled_loop_is_where_the_poles_meet():
    """Koren's sampled loop, T = 5 ms, K free: the largest σ_min over K is where the two
    z-poles meet, z² − tr(K) z + det(K) with tr² = 4 det (both affine in K, Koren eq 18):
    σ* = −ln(tr/2)/T at the root of the discriminant (brentq to 1e-15).

    1e-8 relative (measured 1.1e-9): the factor form's rows (Jury's conditions on the
    quadratic factor) meet at a corner with independent gradients, and their margin (1e-7
    of each row's scale) keeps the tuned poles a complex pair just inside |z| = e^{−σT}.
    Before, the Routh rows of p(e^{−σT}z) vanished quadratically there: IPOPT stopped 6e-5
    short (a violation ε of the rows moves a double root by √ε)."""
    spec = reference_pulse([{"metric": "decay_rate", "goal": "maximize"}], [])
    spec["plant"]["technique"] = "sampled_data"
    spec["tunables"]["sampling_period"] = {"value": 0.005}
    result = tune_dict(spec)
    assert result.success and result.solver.method == "ipopt", result.message
    period, tau = 0.005, 0.02
    x = math.exp(-period / tau)
    phi = np.array([[1, tau * (1 - x)], [0, x]])
    gamma = np.array([[period - tau * (1 - x)], [1 - x]])

    def trace_det(k):
        closed = phi - gamma @ np.array([[k, 0]])
        return np.trace(closed), np.linalg.det(closed)

    k = brentq(lambda k: trace_det(k)[0] ** 2 - 4 * trace_det(k)[1], 1.0, 40.0, xtol=1e-15)
    best = -math.log(trace_det(k)[0] / 2) / period
    value = result.metrics["decay_rate"].value
    assert value == pytest.approx(best, rel=1e-8)
    assert value <= best * (1 + 1e-12)  # inside: the tuned pair's rounding is ~1e-13 of it
    assert validated(result, "decay_rate")["ok"]
