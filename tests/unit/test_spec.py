"""Spec checks beyond the property tests: IPOPT's own option table, an objective term's
``goal`` (minimize/maximize), and the data Bhatia's hydraulic drive needs."""

import json
from pathlib import Path

import pytest

from pydantic import TypeAdapter

from feedtune.schema.spec import (MAX_CONSTRAINTS, MAX_OBJECTIVE_TERMS, IpoptOptions, SpecError,
                                  parse_spec)

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "koren-1979-sampled-data.json"


@pytest.mark.parametrize("name", ["output_file", "option_file_name", "hsllib", "pardisolib",
                                  "print_level", "file_print_level", "print_options_documentation",
                                  "bogus_option", "obj_scaling_factor"])
def test_ipopt_options_outside_the_allow_list_are_refused_listing_the_allowed(name):
    """Options that name a file or a library, print, or change what is optimised: refused
    at their pointer, without asking IPOPT (which would open the file or load the library)."""
    spec = json.loads(EXAMPLE.read_text())
    spec["solver"]["ipopt_options"] = {name: "x", "mu_strategy": "adaptive"}
    with pytest.raises(SpecError) as info:
        parse_spec(spec)
    [(pointer, message)] = info.value.errors
    assert pointer == f"/solver/ipopt_options/{name}"
    allowed = message.split("allowed: ")[1].split(", ")
    assert allowed == sorted(IpoptOptions.__annotations__) and "hessian_approximation" in allowed


@pytest.mark.parametrize("name, field", [("max_iter", "max_iter"), ("tol", "tol"),
                                         ("max_wall_time", "time_limit")])
def test_ipopt_options_the_solver_section_sets_point_there(name, field):
    spec = json.loads(EXAMPLE.read_text())
    spec["solver"]["ipopt_options"] = {name: 50}
    with pytest.raises(SpecError) as info:
        parse_spec(spec)
    assert info.value.errors == [(f"/solver/ipopt_options/{name}",
                                  f"set it as /solver/{field} instead")]


@pytest.mark.parametrize("name, value, message", [
    ("linear_solver", "ma27", "should be 'mumps', not \"ma27\""),
    ("linear_solver", "pardiso", "should be 'mumps', not \"pardiso\""),
    ("nlp_scaling_method", "equilibration-based", "should be 'none' or 'gradient-based'"),
    ("linear_system_scaling", "mc19", "should be 'none' or 'slack-based'"),
    ("bound_frac", 0.6, "less than or equal to 0.5"),
    ("mu_init", 0, "greater than 0"),
    ("mu_init", "0.1", "Input should be a valid number, not a string"),
    ("max_soc", 2.5, "Input should be a valid integer"),
    ("max_soc", True, "Input should be a valid integer, not true"),
    ("limited_memory_max_history", None, "Input should be a valid integer, not null"),
    ("hessian_approximation", ["exact"], "should be 'exact' or 'limited-memory'"),
])
def test_ipopt_option_values_are_checked_by_type_and_range(name, value, message):
    spec = json.loads(EXAMPLE.read_text())
    spec["solver"]["ipopt_options"] = {name: value}
    with pytest.raises(SpecError) as info:
        parse_spec(spec)
    [(pointer, got)] = info.value.errors
    assert pointer == f"/solver/ipopt_options/{name}"
    assert message in got


def _valid_value(name: str):
    """A value inside the allow-list's type and range for option ``name``."""
    schema = IPOPT_SCHEMA["properties"][name]
    if "enum" in schema or "const" in schema:
        return schema["enum"][-1] if "enum" in schema else schema["const"]
    if schema["type"] == "integer":
        return schema.get("minimum", 0) + 1
    return 0.25 if schema.get("maximum", 1) <= 1 else 0.5


IPOPT_SCHEMA = TypeAdapter(IpoptOptions).json_schema()


def test_every_allowed_option_is_one_ipopt_takes_with_that_type():
    """The allow-list is IPOPT 3.14's own table, checked against the IPOPT CasADi bundles:
    every option at a value of its declared type and range solves a small NLP."""
    import casadi as ca

    options = {name: _valid_value(name) for name in IPOPT_SCHEMA["properties"]}
    options["mumps_pivtol"], options["mumps_pivtolmax"] = 1e-6, 0.25
    spec = json.loads(EXAMPLE.read_text())
    spec["solver"]["ipopt_options"] = options
    parsed = parse_spec(spec).solver.ipopt_options
    assert parsed == options and all(type(parsed[k]) is type(options[k]) for k in options)
    x = ca.MX.sym("x")
    solver = ca.nlpsol("allow_list", "ipopt", {"x": x, "f": (x - 1) ** 2},
                       {"ipopt": {**parsed, "print_level": 0, "sb": "yes", "option_file_name": ""},
                        "print_time": False, "error_on_fail": False})
    solver(x0=3, lbx=0, ubx=10)
    assert solver.stats()["return_status"] in ("Solve_Succeeded", "Solved_To_Acceptable_Level")


def test_a_whole_number_for_a_real_option_reaches_ipopt_as_a_real():
    """IPOPT refuses an integer for a Number option (type mismatch): 1 becomes 1.0."""
    spec = json.loads(EXAMPLE.read_text())
    spec["solver"]["ipopt_options"] = {"mu_init": 1, "max_soc": 2, "mu_strategy": "adaptive"}
    options = parse_spec(spec).solver.ipopt_options
    assert options == {"mu_init": 1.0, "max_soc": 2, "mu_strategy": "adaptive"}
    assert type(options["mu_init"]) is float and type(options["max_soc"]) is int


def test_the_tuner_refuses_library_options_whoever_builds_its_settings():
    """Defence in depth: feedtune.tuner takes no option that loads a library, even from a
    caller that did not go through parse_spec."""
    from feedtune.tuner import Settings

    for options in ({"hsllib": "/tmp/x.so"}, {"linear_solver": "ma27"},
                    {"nlp_scaling_method": "equilibration-based"}):
        with pytest.raises(ValueError, match="would load a library"):
            Settings(ipopt_options=options)
    assert Settings(ipopt_options={"linear_solver": "mumps"}).ipopt_options


# -- objective goal ----------------------------------------------------------------------------

BHATIA = Path(__file__).resolve().parents[2] / "examples" / "bhatia-1971-hydraulic.json"


def _bhatia() -> dict:
    return json.loads(BHATIA.read_text())


def test_goal_maximize_parses_and_minimize_is_the_default():
    spec = parse_spec(_bhatia())
    assert spec.objective[0].metric == "bandwidth" and spec.objective[0].goal == "maximize"
    koren = parse_spec(json.loads(EXAMPLE.read_text()))
    assert all(term.goal == "minimize" for term in koren.objective)


def test_goal_is_part_of_the_canonical_hash():
    spec = _bhatia()
    maximize = parse_spec(spec).sha256()
    spec["objective"][0]["goal"] = "minimize"
    explicit = parse_spec(spec).sha256()
    assert explicit != maximize
    del spec["objective"][0]["goal"]
    assert parse_spec(spec).sha256() == explicit  # the default, spelled out or not


@pytest.mark.parametrize("value", ["maximise", "MAXIMIZE", "max", "", 1, None, True, ["maximize"]])
def test_bad_goal_names_the_field(value):
    spec = _bhatia()
    spec["objective"][0]["goal"] = value
    with pytest.raises(SpecError) as info:
        parse_spec(spec)
    assert [pointer for pointer, _ in info.value.errors] == ["/objective/0/goal"]
    assert "'minimize' or 'maximize'" in info.value.errors[0][1]


def test_goal_is_not_a_constraint_field():
    spec = _bhatia()
    spec["constraints"][2]["goal"] = "maximize"
    with pytest.raises(SpecError) as info:
        parse_spec(spec)
    assert info.value.errors == [("/constraints/2/goal", "Extra inputs are not permitted")]


@pytest.mark.parametrize("goal, bound, damping", [("minimize", "max", 0.5), ("maximize", "min", 2.5)])
def test_goal_maximize_maximizes(goal, bound, damping):
    """Koren's continuous loop, ζ = 1/(2√(Kτ)) (eq 9), K in [2, 50] 1/s, τ = 20 ms: the
    least damping is at K = 50 (ζ = 0.5), the most at K = 2 (ζ = 2.5). The result's
    objective is the weighted sum with maximised terms counted negatively."""
    from feedtune.problem import tune

    spec = parse_spec({
        "name": "goal", "plant": {"type": "software_servo", "technique": "reference_pulse",
                                  "time_constant": 0.02, "blu": 5e-6, "max_velocity": 0.04},
        "tunables": {"position_gain": {"min": 2, "max": 50}},
        "objective": [{"metric": "damping_ratio", "goal": goal, "weight": 3}],
        "solver": {"multistart": 2}})
    result = tune(spec)
    assert result.success
    assert result.tuned["position_gain"].at_bound == bound
    assert result.metrics["damping_ratio"].value == pytest.approx(damping, rel=1e-6)
    sign = 1 if goal == "minimize" else -1
    assert result.objective == pytest.approx(sign * 3 * damping, rel=1e-6)


# -- hydraulic_rotary data -------------------------------------------------------------------

HYDRAULIC_DATA = ("bulk_modulus", "total_volume", "inertia", "leakage_coefficient")


@pytest.mark.parametrize("removed, named", [
    # ω_n and ξ both given: the load-path data is optional
    (HYDRAULIC_DATA, None),
    # ξ given, ω_n computed from β_e, V_t, J_t
    (("hydraulic_natural_frequency", "bulk_modulus"), ["bulk_modulus"]),
    (("hydraulic_natural_frequency", "total_volume", "inertia"), ["total_volume", "inertia"]),
    # ω_n given, ξ computed: K_ce too
    (("hydraulic_damping", "leakage_coefficient"), ["leakage_coefficient"]),
    # nothing to compute either from
    (("hydraulic_natural_frequency", "hydraulic_damping") + HYDRAULIC_DATA, list(HYDRAULIC_DATA)),
])
def test_hydraulic_rotary_without_its_hydraulic_data(removed, named):
    """Bhatia's drive needs ω_n and ξ, given or computed (App. A2); a spec without either
    is an error at /plant naming every missing field, once, in one message."""
    spec = _bhatia()
    for field in removed:
        del spec["plant"][field]
    if named is None:
        assert parse_spec(spec).plant.hydraulic_natural_frequency == 75.0
        return
    with pytest.raises(SpecError) as info:
        parse_spec(spec)
    assert len(info.value.errors) == 1
    pointer, message = info.value.errors[0]
    assert pointer == "/plant"
    assert "hydraulic_natural_frequency" in message and "hydraulic_damping" in message
    listed = message.split("missing: ")[1].split(", ")
    assert listed == named


@pytest.mark.parametrize("field", ["torque_motor_gain", "torque_motor_time_constant", "flow_gain",
                                   "displacement"])
def test_hydraulic_rotary_required_fields_are_named(field):
    spec = _bhatia()
    del spec["plant"][field]
    with pytest.raises(SpecError) as info:
        parse_spec(spec)
    assert (f"/plant/{field}", "Field required") in info.value.errors


def test_hydraulic_rotary_unknown_compensator_kind_is_named():
    spec = _bhatia()
    spec["plant"]["velocity_compensator"] = "lead"
    with pytest.raises(SpecError) as info:
        parse_spec(spec)
    assert info.value.errors[0][0] == "/plant/velocity_compensator"
    assert "'none', 'lag' or 'lag_lead'" in info.value.errors[0][1]


def test_compensator_tunables_need_the_compensator():
    """velocity_compensator.tau1 exists only with a velocity compensator."""
    spec = _bhatia()
    spec["plant"]["velocity_compensator"] = "none"
    with pytest.raises(SpecError) as info:
        parse_spec(spec)
    pointers = [pointer for pointer, _ in info.value.errors]
    assert pointers == ["/tunables/velocity_compensator.tau1", "/tunables/velocity_compensator.tau2",
                        "/tunables/velocity_compensator.tau12"]
    assert "unknown tunable" in info.value.errors[0][1]


# -- all errors in one pass ----------------------------------------------------------------

def test_schema_and_registry_errors_come_together():
    """A bad weight (schema) no longer hides an unknown tunable, an unsupported metric,
    empty bounds and a bad IPOPT option (registry checks): one SpecError has them all."""
    spec = json.loads(EXAMPLE.read_text())
    spec["objective"][0]["weight"] = -1
    spec["tunables"]["velocity_gain"] = {"min": 1, "max": 2}
    spec["tunables"]["position_gain"] = {"min": 300, "max": 200}
    spec["constraints"].append({"metric": "sensitivity", "min": 1000})
    spec["solver"]["ipopt_options"] = {"output_file": "/tmp/x"}
    with pytest.raises(SpecError) as info:
        parse_spec(spec)
    errors = dict(info.value.errors)
    assert set(errors) == {"/objective/0/weight", "/tunables/velocity_gain",
                           "/tunables/position_gain", "/constraints/1/metric",
                           "/solver/ipopt_options/output_file"}
    assert "unknown tunable" in errors["/tunables/velocity_gain"]
    assert "min (300.0) is greater than max (200.0)" in errors["/tunables/position_gain"]


def test_an_unsupported_metric_lists_the_metrics_this_plant_supports():
    spec = json.loads(EXAMPLE.read_text())
    spec["constraints"] = [{"metric": "sensitivity", "min": 10}]
    with pytest.raises(SpecError) as info:
        parse_spec(spec)
    [(pointer, message)] = info.value.errors
    assert pointer == "/constraints/0/metric"
    assert "software_servo(technique=sampled_data)" in message  # the configuration it names
    listed = message.split("supported here: ")[1].split(", ")
    assert "radial_error" in listed and "bandwidth" in listed and "sensitivity" not in listed
    # exactly the metrics the loop supports, the new pole metrics and M_s among them
    assert {"decay_rate", "pole_damping", "sensitivity_peak"} <= set(listed)


def test_a_term_that_fails_the_schema_is_still_checked_against_the_plant():
    """sensitivity (Bhatia's loops only) with a bad weight on Koren's sampled loop: both
    problems at once."""
    spec = json.loads(EXAMPLE.read_text())
    spec["objective"].append({"metric": "sensitivity", "weight": "heavy"})
    with pytest.raises(SpecError) as info:
        parse_spec(spec)
    errors = dict(info.value.errors)
    assert set(errors) == {"/objective/1/weight", "/objective/1/metric"}
    assert "not a string" in errors["/objective/1/weight"]
    assert "not defined for this plant configuration" in errors["/objective/1/metric"]


def test_empty_bounds_and_a_start_outside_them_are_spec_errors():
    """What tune's resolve_tunables refused after validation, parse_spec refuses first."""
    spec = json.loads(EXAMPLE.read_text())
    spec["tunables"]["position_gain"] = {"min": 2000}  # above the default max, 1000 1/s
    spec["tunables"]["sampling_period"] = {"min": 0.01, "max": 0.02, "initial": 0.5}
    with pytest.raises(SpecError) as info:
        parse_spec(spec)
    errors = dict(info.value.errors)
    assert set(errors) == {"/tunables/position_gain", "/tunables/sampling_period/initial"}
    assert "are empty" in errors["/tunables/position_gain"]


def test_the_step_response_sample_limit_is_a_spec_error_at_the_term():
    """20·(2τ/T_min + 1) samples, τ = 20 ms, T in [1 µs, 20 ms]: 800 021 (20·0.04002 s in
    steps of 1 µs, rounded up), over the tuner's 50 000: refused by parse_spec (validate and
    tune alike); at T_min = 0.1 ms (8 020 samples) accepted."""
    spec = json.loads(EXAMPLE.read_text())
    spec["objective"] = [{"metric": "radial_error", "radius": 0.008, "feed": 0.04},
                         {"metric": "iae", "weight": 0.1}]
    spec["tunables"]["sampling_period"] = {"min": 1e-6, "max": 0.02}
    with pytest.raises(SpecError) as info:
        parse_spec(spec)
    [(pointer, message)] = info.value.errors
    assert pointer == "/objective/1/metric"
    assert "800021 samples (limit 50000)" in message
    spec["tunables"]["sampling_period"] = {"min": 1e-4, "max": 0.02}
    assert parse_spec(spec).objective[1].metric == "iae"


def test_objective_terms_are_bounded():
    spec = json.loads(EXAMPLE.read_text())
    spec["objective"] = spec["objective"] * (MAX_OBJECTIVE_TERMS + 1)
    with pytest.raises(SpecError) as info:
        parse_spec(spec)
    assert info.value.errors == [("/objective", f"Array should have at most {MAX_OBJECTIVE_TERMS} "
                                                f"items, not {MAX_OBJECTIVE_TERMS + 1}")]


def test_a_longer_horizon_over_the_sample_limit_keeps_the_first_result(monkeypatch):
    """Tune lengthens the step horizon when the first NLP is inexact; a lengthened horizon
    over the sample limit used to turn a spec validate had passed into a spec error. Now
    the result is the shorter horizon's, and its message says why. (Koren's lightly damped
    IAE case, delay 1, K ≥ 40 1/s, T = 1/64 s, needs a longer horizon than the first;
    a growth of 10⁵ puts the second at 9.1 million samples.)"""
    import feedtune.problem as problem

    monkeypatch.setattr(problem, "HORIZON_GROWTH", 1e5)
    result = problem.tune(parse_spec({
        "name": "lightly-damped",
        "plant": {"type": "software_servo", "technique": "sampled_data", "time_constant": 0.02,
                  "blu": 5e-6, "max_velocity": 0.04, "computation_delay": 1},
        "tunables": {"position_gain": {"min": 40.0, "max": 200},
                     "sampling_period": {"value": 1 / 64}},
        "objective": [{"metric": "iae"}],
        "solver": {"multistart": 2}}))
    assert result.status != "error" and result.solver.starts
    assert "100000x longer step-response horizon is over the sample limit" in result.message
    assert "needs 9120001 samples (limit 50000)" in result.message


def test_integer_ratio_leaves_room_for_the_constraint_it_adds():
    """integer_ratio solves again with one more constraint (q whole); a spec already at
    the constraint limit would be refused by tune only, so parse_spec refuses it."""
    spec = json.loads((EXAMPLE.parent / "sato-finish.json").read_text())
    spec["plant"]["integer_ratio"] = True
    spec["plant"]["interpolation"] = "linear"
    bound = {"metric": "interpolation_ratio", "min": 1}
    spec["constraints"] = [bound] * (MAX_CONSTRAINTS - 1)
    assert len(parse_spec(spec).constraints) == MAX_CONSTRAINTS - 1
    spec["constraints"] = [bound] * MAX_CONSTRAINTS
    with pytest.raises(SpecError) as info:
        parse_spec(spec)
    assert info.value.errors == [("/constraints", f"at most {MAX_CONSTRAINTS - 1} constraints "
                                                  "with integer_ratio, which adds one (q = a "
                                                  "whole number)")]


def test_options_that_bypass_parse_spec_end_in_a_result_not_a_traceback():
    """A Spec built without parse_spec's checks (model_construct) and an option that loads
    a library: the tuner refuses it, and tune says so in a result with status error."""
    from feedtune.problem import tune

    spec = parse_spec(json.loads(EXAMPLE.read_text()))
    solver = spec.solver.model_construct(**{**dict(spec.solver), "ipopt_options": {
        "linear_solver": "ma27", "hsllib": "/nonexistent/libhsl.so"}})
    result = tune(spec.model_construct(**{**dict(spec), "solver": solver}))
    assert result.status == "error" and not result.success
    assert "would load a library" in result.message


def _errors(validate, item, strict):
    """(type, loc, msg) of each error of ``validate(item, strict=strict)``; [] if valid."""
    from pydantic import ValidationError

    try:
        validate(item, strict=strict)
    except ValidationError as exc:
        return [(e["type"], e["loc"], e["msg"]) for e in exc.errors()]
    return []


@pytest.mark.parametrize("build", ["objective", "constraint"])
def test_a_term_builds_only_its_metrics_model_and_validates_as_the_whole_union(build):
    """Issue 15's start-up: an item builds the model of the metric it names, not all 44
    metrics' (MetricTerms); its validation, error locations and messages, strict and lax,
    are the whole discriminated union's, which an unknown or missing tag still gets."""
    from feedtune.objectives import METRICS
    from feedtune.schema import spec as module

    make = module._objective_model if build == "objective" else module._constraint_model
    built = []
    terms = module.MetricTerms(lambda name, metric: built.append(name) or make(name, metric))
    whole = TypeAdapter(module._tagged_union(tuple(make(n, m) for n, m in METRICS.items()),
                                             "metric"))
    valid = terms.validate_python({"metric": "iae", "min": 1.0}
                                  if build == "constraint" else {"metric": "iae"}, strict=True)
    assert built == ["iae"] and type(valid).__name__ == f"Iae{build.capitalize()}"
    items = [{"metric": name, **extra} for name in ("iae", "phase_margin", "decay_rate")
             for extra in ({}, {"weight": "2"}, {"weight": True}, {"min": 2, "max": 1},
                           {"max": 1.0}, {"bogus": 1}, {"goal": "maximize"})]
    items += [{"metric": "nope"}, {"metric": 3}, {"weight": 1}, [], "iae", {"metric": None}]
    for item in items:
        for strict in (True, False):
            expected = _errors(whole.validate_python, item, strict)
            assert _errors(terms.validate_python, item, strict) == expected, (item, strict)
    assert sorted(built) == sorted(METRICS)  # the unknown tags built the whole union
