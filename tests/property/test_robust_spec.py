"""Properties of the uncertain plant-parameter forms (feedtune.schema.uncertainty): a list,
a min/max range (with an optional nominal) and a nominal with a tolerance parse to the
nominal value in ``plant`` and the set or range in ``robust.parameters``; the canonical
spec parses back to itself; a malformed form is a SpecError whose pointers name the
place written; a parameter that is not one of the plant's numbers is refused there."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hypothesis_text import utf8_text

from feedtune.schema.spec import Spec, SpecError, parse_spec
from feedtune.schema.uncertainty import MAX_SCENARIOS, MAX_VALUES

REPO = Path(__file__).resolve().parents[2]
SERVO = json.loads((REPO / "examples" / "koren-1979-sampled-data.json").read_text())
HYDRAULIC = json.loads((REPO / "examples" / "bhatia-1971-hydraulic.json").read_text())
SETTINGS = settings(max_examples=150, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])

#: time constants a servo accepts [s]: positive, within a span the loop is formed in
taus = st.floats(min_value=1e-3, max_value=0.1, allow_nan=False)


def with_tau(form) -> dict:
    spec = copy.deepcopy(SERVO)
    spec["plant"]["time_constant"] = form
    return spec


def _outcome(data):
    try:
        return parse_spec(data)
    except SpecError as exc:
        return exc


@SETTINGS
@given(values=st.lists(taus, min_size=1, max_size=MAX_VALUES))
def test_a_list_is_its_values_with_the_first_nominal(values):
    spec = parse_spec(with_tau(values))
    assert spec.plant.time_constant == values[0]
    assert spec.robust.parameters["time_constant"].values == values
    assert spec.robust.objective == "nominal"


@SETTINGS
@given(low=taus, high=taus, nominal=st.none() | taus)
def test_a_range_is_min_max_and_its_nominal(low, high, nominal):
    form = {"min": low, "max": high, **({"nominal": nominal} if nominal is not None else {})}
    outcome = _outcome(with_tau(form))
    middle = (low + high) / 2 if nominal is None else nominal
    if low < high and low <= middle <= high:
        assert isinstance(outcome, Spec), outcome
        assert outcome.plant.time_constant == middle
        uncertain = outcome.robust.parameters["time_constant"]
        assert (uncertain.min, uncertain.max) == (low, high)
    else:  # an empty range, or a nominal outside it
        assert isinstance(outcome, SpecError)
        assert all(p.startswith("/plant/time_constant") for p, _ in outcome.errors), outcome


@SETTINGS
@given(nominal=taus, percent=st.floats(min_value=-50, max_value=150, allow_nan=False))
def test_a_tolerance_is_the_range_around_the_nominal(nominal, percent):
    outcome = _outcome(with_tau({"nominal": nominal, "tolerance_percent": percent}))
    spread = nominal * percent / 100
    if 0 < percent < 100 and nominal - spread < nominal + spread:
        assert isinstance(outcome, Spec), outcome
        uncertain = outcome.robust.parameters["time_constant"]
        assert outcome.plant.time_constant == nominal
        assert uncertain.min == pytest.approx(nominal * (1 - percent / 100), rel=1e-12)
        assert uncertain.max == pytest.approx(nominal * (1 + percent / 100), rel=1e-12)
    elif 0 < percent < 100:  # a tolerance so small that the range rounds to one value
        assert outcome.errors[0][0] == "/plant/time_constant"
    else:
        assert outcome.errors == [("/plant/time_constant/tolerance_percent", outcome.errors[0][1])]


forms = (st.lists(taus, min_size=1, max_size=4)
         | st.builds(lambda a, b: {"min": min(a, b), "max": max(a, b)}, taus, taus)
         | st.builds(lambda n, p: {"nominal": n, "tolerance_percent": p}, taus,
                     st.floats(min_value=1, max_value=60)))


@SETTINGS
@given(form=forms, objective=st.sampled_from(["nominal", "worst_case"]))
def test_the_canonical_spec_parses_back_to_itself(form, objective):
    spec = _outcome({**with_tau(form), "robust": {"objective": objective}})
    if isinstance(spec, SpecError):  # a range of equal ends: min < max is required
        assert spec.errors[0][0].startswith("/plant/time_constant"), spec.errors
        return
    again = parse_spec(json.loads(json.dumps(spec.model_dump(mode="json"))))
    assert again == spec and again.sha256() == spec.sha256()
    assert again.robust.objective == objective


malformed = st.one_of(
    st.lists(utf8_text(max_size=3) | st.none() | st.booleans(), min_size=1, max_size=3),
    st.just([]),
    st.lists(taus, min_size=MAX_VALUES + 1, max_size=MAX_VALUES + 3),
    st.fixed_dictionaries({"min": st.floats(max_value=0, allow_nan=False, allow_infinity=False), "max": taus}),
    st.fixed_dictionaries({"min": taus}),
    st.fixed_dictionaries({"nominal": utf8_text(max_size=3), "tolerance_percent": st.just(10)}),
    st.fixed_dictionaries({"min": taus, "max": taus, "tolerance_percent": st.just(10)}),
    st.fixed_dictionaries({"values": st.lists(taus, max_size=2)}),
)


@SETTINGS
@given(form=malformed)
def test_a_malformed_form_is_named_where_it_was_written(form):
    outcome = _outcome(with_tau(form))
    assert isinstance(outcome, SpecError), outcome
    for pointer, message in outcome.errors:
        assert pointer.startswith("/plant/time_constant"), (pointer, message)
        assert message
    # the text path (what the CLI reads) agrees
    text = _outcome(json.dumps(with_tau(form)))
    assert isinstance(text, SpecError) and text.errors == outcome.errors


def test_only_the_plants_numbers_may_be_uncertain():
    """Bhatia's example gives ω_n and ξ: the inertia then enters no arithmetic of the loop
    (it is not one of the plant's numbers) and cannot be uncertain; ω_n can."""
    spec = copy.deepcopy(HYDRAULIC)
    spec["plant"]["inertia"] = {"nominal": 0.0135582, "tolerance_percent": 30}
    with pytest.raises(SpecError) as exc:
        parse_spec(spec)
    assert exc.value.errors[0][0] == "/plant/inertia"
    assert "hydraulic_natural_frequency" in exc.value.errors[0][1]
    spec["plant"]["inertia"] = 0.0135582
    spec["plant"]["hydraulic_natural_frequency"] = [75.0, 60.0, 90.0]
    assert parse_spec(spec).robust.parameters["hydraulic_natural_frequency"].values == [
        75.0, 60.0, 90.0]


def test_a_parameter_given_twice_and_too_many_scenarios_are_refused():
    twice = with_tau([0.01, 0.02])
    twice["robust"] = {"parameters": {"time_constant": {"min": 0.01, "max": 0.02}}}
    with pytest.raises(SpecError) as exc:
        parse_spec(twice)
    assert ("/plant/time_constant", "given twice: here and in /robust/parameters") in exc.value.errors
    many = with_tau([0.01 + 0.001 * i for i in range(MAX_VALUES)])
    many["plant"]["blu"] = [5e-6, 1e-5, 2e-5]  # 16 × 3 corners + 1 > MAX_SCENARIOS
    with pytest.raises(SpecError) as exc:
        parse_spec(many)
    assert exc.value.errors[0][0] == "/plant" and str(MAX_SCENARIOS) in exc.value.errors[0][1]


def test_an_empty_robust_section_and_a_nominal_outside_the_set_are_refused():
    with pytest.raises(SpecError) as exc:
        parse_spec({**copy.deepcopy(SERVO), "robust": {"objective": "worst_case"}})
    assert exc.value.errors[0][0] == "/robust/parameters"
    outside = copy.deepcopy(SERVO)
    outside["robust"] = {"parameters": {"time_constant": {"values": [0.01, 0.03]}}}
    with pytest.raises(SpecError) as exc:
        parse_spec(outside)
    assert exc.value.errors[0][0] == "/robust/parameters/time_constant"
    assert "nominal value 0.02" in exc.value.errors[0][1]


def test_robust_tuning_with_a_whole_interpolation_ratio_is_refused():
    spec = json.loads((REPO / "examples" / "sato-finish.json").read_text())
    spec["plant"].update(integer_ratio=True, time_constant=[0.01, 0.02])
    with pytest.raises(SpecError) as exc:
        parse_spec(spec)
    assert exc.value.errors[0][0] == "/robust" and "integer_ratio" in exc.value.errors[0][1]
