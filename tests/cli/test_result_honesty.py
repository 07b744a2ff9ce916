"""A result says what is true of the tuned design, through the real entry point.

Issue 14: constraints of an unstable loop are not met, a flat optimum is reported as not
unique with a way out, a start without a stable point says so, implausible designs warn,
and success needs a finite objective.
"""

from __future__ import annotations

import copy
import json
import subprocess
from pathlib import Path

import pytest

from feedtune.schema.spec import parse_spec
from feedtune_cli import run_cli

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"

#: Koren's design example drive (τ 20 ms, BLU 5 µm, V_m 40 mm/s), sampled data
SERVO = {"type": "software_servo", "technique": "sampled_data", "time_constant": 0.02,
         "blu": 5e-6, "max_velocity": 0.04}


def tune(tmp_path: Path, spec: dict, *args: str) -> tuple[subprocess.CompletedProcess, dict]:
    path = tmp_path / f"{spec['name']}.json"
    path.write_text(json.dumps(spec))
    out = tmp_path / f"{spec['name']}.result.json"
    proc = run_cli("tune", str(path), "-o", str(out), *args, text=True)
    assert proc.returncode in (0, 1), proc.stderr
    return proc, json.loads(out.read_text())


def test_unstable_loop_meets_no_constraint(tmp_path):
    # K = 300 1/s with T = 15.6 ms: spectral radius 1.25. Counter utilisation (0.98) and the
    # encoder ratio (125) are numbers of the design that would pass their bounds; on an
    # unstable loop they are still not met.
    spec = {"name": "unstable", "plant": SERVO,
            "tunables": {"position_gain": {"value": 300}, "sampling_period": {"value": 0.015625}},
            "objective": [{"metric": "iae"}],
            "constraints": [{"metric": "counter_utilisation", "max": 1.3},
                            {"metric": "encoder_ratio", "min": 1}]}
    proc, result = tune(tmp_path, spec)
    assert proc.returncode == 1
    assert result["stability"]["stable"] is False
    assert result["objective"] is None
    assert [c["satisfied"] for c in result["constraints"]] == [False, False]
    assert [c["value"] for c in result["constraints"]] == [None, None]
    assert "OK" not in [line.split()[-1] for line in proc.stderr.splitlines() if " = " in line]
    assert proc.stderr.count("NOT MET (loop unstable)") == 2
    # one solve: a longer step horizon cannot make an unstable loop settle
    assert "longer step-response horizon" not in proc.stderr


FLAT = {"name": "flat", "plant": SERVO,
        "tunables": {"position_gain": {"min": 1, "max": 200},
                     "sampling_period": {"min": 0.001, "max": 0.02}},
        "objective": [{"metric": "radial_error", "radius": 0.008, "feed": 0.04}]}


def test_flat_optimum_is_not_unique(tmp_path):
    # zero radial error holds along a curve K(T) (docs/design.md, numerical notes): every
    # start ends on it, at the point IPOPT's barrier prefers, so only the reduced Hessian
    # can tell
    proc, result = tune(tmp_path, FLAT)
    assert result["success"] is True
    optimum = result["optimum"]
    assert optimum["unique"] is False
    assert optimum["flat"] == ["position_gain", "sampling_period"]
    assert "secondary objective" in optimum["advice"] and "value" in optimum["advice"]
    assert "optimum: NOT UNIQUE" in proc.stderr
    assert "to pick one:" in proc.stderr


@pytest.mark.parametrize("change", ["secondary_objective", "fixed_period"])
def test_flat_optimum_made_unique_as_advised(tmp_path, change):
    spec = copy.deepcopy(FLAT)
    spec["name"] = change
    if change == "secondary_objective":  # a tiny f_m/f_s term prefers the shortest period
        spec["objective"].append({"metric": "encoder_ratio", "weight": 1e-9})
    else:
        spec["tunables"]["sampling_period"] = {"value": 0.005}
    proc, result = tune(tmp_path, spec)
    assert result["success"] is True
    assert result["optimum"]["unique"] is True
    assert result["optimum"]["flat"] == [] and result["optimum"]["spread"] == {}
    assert "NOT UNIQUE" not in proc.stderr
    # still on the zero-error curve: far below a BLU (5 µm)
    assert result["metrics"]["radial_error"]["value"] < 1e-6 * 5e-6


def test_unique_optimum_of_the_design_example(tmp_path):
    spec = json.loads((EXAMPLES / "koren-1979-sampled-data.json").read_text())
    proc, result = tune(tmp_path, spec)
    assert result["optimum"]["unique"] is True
    assert result["optimum"]["starts"] == list(range(1, 9))
    assert "NOT UNIQUE" not in proc.stderr


def test_start_without_a_stable_point_says_so(tmp_path):
    # every K in [300, 400] 1/s is unstable at T = 15.6 ms: nothing can be solved
    spec = {"name": "nostable", "plant": SERVO,
            "tunables": {"position_gain": {"min": 300, "max": 400},
                         "sampling_period": {"value": 0.015625}},
            "objective": [{"metric": "iae"}], "solver": {"multistart": 2}}
    proc, result = tune(tmp_path, spec)
    assert proc.returncode == 1
    lines = [line for line in proc.stderr.splitlines() if line.startswith("start ")]
    assert len(lines) == 2
    assert all("no stable start" in line and "objective" not in line for line in lines)
    assert all(s["objective"] is None and s["return_status"] == "No_Stable_Start"
               for s in result["solver"]["starts"])
    assert result["message"].startswith("no stable start")


def test_implausible_designs_warn(tmp_path):
    spec = json.loads((EXAMPLES / "koren-1979-sampled-data.json").read_text())
    spec["name"] = "implausible"
    spec["tunables"]["sampling_period"] = {"value": 0.02}  # 8000 pulse/s · 20 ms = 160 > 128
    spec["objective"] = [{"metric": "radial_error", "radius": 0.005, "feed": 0.04},
                         {"metric": "radial_error", "radius": 20.0, "feed": 0.04}]
    proc, result = tune(tmp_path, spec, "-q")
    warnings = result["warnings"]
    assert any("counter overflows" in w and "1.25" in w for w in warnings)
    assert any(w.startswith("min_radius") and "0.005 m circle of /objective/0" in w for w in warnings)
    assert any(w.startswith("/objective/1/radius") and "20 m" in w for w in warnings)
    assert not any("/objective/0/radius" in w for w in warnings)
    for w in warnings:  # on stderr too, even with -q
        assert f"warning: implausible: {w}" in proc.stderr


def test_plausible_design_has_no_warning(tmp_path):
    spec = json.loads((EXAMPLES / "koren-1979-sampled-data.json").read_text())
    _, result = tune(tmp_path, spec)
    assert result["warnings"] == []


def test_hydraulic_data_that_contradict_the_given_natural_frequency():
    from feedtune.plausibility import plausibility_warnings

    spec = json.loads((EXAMPLES / "bhatia-1971-hydraulic.json").read_text())
    warnings = plausibility_warnings(parse_spec(spec), {})
    # Bhatia designs with ω_n = 75 rad/s; his β_e, V_t, J_t, D_m give √(4β_e D_m²/(V_t J_t))
    # = 28.1 rad/s (App. A2). His ξ = 0.5 is what K_ce was chosen for: no second warning.
    assert len(warnings) == 1
    assert "given ω_n = 75 rad/s" in warnings[0] and "28.12 rad/s" in warnings[0]
    consistent = copy.deepcopy(spec)
    del consistent["plant"]["hydraulic_natural_frequency"]
    assert plausibility_warnings(parse_spec(consistent), {}) == []
    damped = copy.deepcopy(consistent)
    damped["plant"]["hydraulic_damping"] = 0.8
    (warning,) = plausibility_warnings(parse_spec(damped), {})
    assert "given ξ = 0.8" in warning and "ξ = 0.5" in warning


def test_success_needs_a_finite_objective(monkeypatch):
    from feedtune import problem
    from feedtune.tuner.nlp import Problem

    evaluate = Problem._evaluate_numeric

    def objective_lost(self, values):
        _, *rest = evaluate(self, values)
        return (None, *rest)

    monkeypatch.setattr(Problem, "_evaluate_numeric", objective_lost)
    spec = parse_spec((EXAMPLES / "koren-1979-sampled-data.json").read_text())
    result = problem.tune(spec)
    assert result.success is False
    assert result.status == "error"
    assert result.objective is None
    assert "not a finite number" in result.message
