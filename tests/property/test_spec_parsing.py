"""Properties of spec parsing: whatever arrives, the answer is a Spec or a SpecError whose
pointers name places in the input, and the canonical hash ignores key order and
spelled-out defaults."""

from __future__ import annotations

import copy
import itertools
import json
import re
import typing
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from hypothesis_text import utf8_text

from feedtune.objectives import METRICS
from feedtune.plants import PLANTS
from feedtune.schema.spec import (MAX_JSON_DEPTH, SolverSpec, Spec, SpecError, TunableSpec,
                                  parse_spec)

REPO = Path(__file__).resolve().parents[2]
EXAMPLE_PATH = REPO / "examples" / "koren-1979-sampled-data.json"
EXAMPLE_BYTES = EXAMPLE_PATH.read_bytes()
EXAMPLE: dict = json.loads(EXAMPLE_BYTES)

SETTINGS = settings(max_examples=300, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])


# -- JSON helpers ------------------------------------------------------------------------

def paths(node: Any, prefix: tuple = ()) -> list[tuple]:
    """Every path below the root of a JSON tree (dict keys and list indices)."""
    out = []
    if isinstance(node, dict):
        items = node.items()
    elif isinstance(node, list):
        items = enumerate(node)
    else:
        return out
    for key, child in items:
        out.append(prefix + (key,))
        out.extend(paths(child, prefix + (key,)))
    return out


EXAMPLE_PATHS = paths(EXAMPLE)


def _example_per_plant() -> dict[str, dict]:
    """One bundled example spec per plant type that has one (first by file name): the
    one-field mutations below run on every plant's spec, not only Koren's."""
    found: dict[str, dict] = {}
    for path in sorted((REPO / "examples").glob("*.json")):
        doc = json.loads(path.read_bytes())
        found.setdefault(doc["plant"]["type"], doc)
    return found


PLANT_EXAMPLES = _example_per_plant()
#: (plant type, path) for every path of every plant's example
MUTATION_SITES = [(plant, path) for plant, doc in PLANT_EXAMPLES.items() for path in paths(doc)]


def replaced(doc: Any, path: tuple, value: Any) -> Any:
    doc = copy.deepcopy(doc)
    node = doc
    for part in path[:-1]:
        node = node[part]
    node[path[-1]] = value
    return doc


def deleted(doc: Any, path: tuple) -> Any:
    doc = copy.deepcopy(doc)
    node = doc
    for part in path[:-1]:
        node = node[part]
    del node[path[-1]]
    return doc


def tokens(pointer: str) -> list[str]:
    """RFC 6901 reference tokens of a non-empty pointer."""
    assert pointer.startswith("/"), pointer
    return [t.replace("~1", "/").replace("~0", "~") for t in pointer[1:].split("/")]


_MISSING = object()


def resolve(doc: Any, parts: list[str]) -> Any:
    node = doc
    for part in parts:
        if isinstance(node, dict) and part in node:
            node = node[part]
        elif (isinstance(node, list) and part.isdigit() and str(int(part)) == part
              and int(part) < len(node)):
            node = node[int(part)]
        else:
            return _MISSING
    return node


def assert_pointer_names_the_input(pointer: str, doc: Any) -> None:
    """``pointer`` is "" (the whole document), resolves in ``doc``, or names a missing key
    of an object that does exist in ``doc`` (a required field left out)."""
    if pointer == "":
        return
    parts = tokens(pointer)
    if resolve(doc, parts) is not _MISSING:
        return
    parent = resolve(doc, parts[:-1])
    assert isinstance(parent, dict) and parts[-1] not in parent, (
        f"error pointer {pointer!r} names nothing in the input")


def assert_well_formed(exc: SpecError) -> None:
    assert exc.errors, "a SpecError without errors"
    for pointer, message in exc.errors:
        assert isinstance(pointer, str) and isinstance(message, str) and message
        assert pointer == "" or pointer.startswith("/")


# -- strategies --------------------------------------------------------------------------

def _field_names() -> set[str]:
    names = set(Spec.model_fields) | set(SolverSpec.model_fields) | set(TunableSpec.model_fields)
    for plant_type, plant in PLANTS.items():
        names |= set(plant.Params.model_fields)
        choices = {name: typing.get_args(info.annotation)
                   for name, info in plant.Params.model_fields.items()
                   if name != "type" and typing.get_origin(info.annotation) is typing.Literal}
        for values in choices.values():
            names |= set(values)
        # tunables depend on the structure-selecting Literal fields (technique, compensator
        # kinds) only: every combination of them, other fields left unvalidated
        for combination in itertools.product(*choices.values()):
            params = plant.Params.model_construct(type=plant_type,
                                                  **dict(zip(choices, combination)))
            names |= set(plant(params).tunables())
    for metric in METRICS.values():
        names |= set(metric.Options.model_fields)
    names |= {"metric", "weight", "min", "max", "value"}
    return names


#: words the spec gives meaning to, so generated objects sometimes get past the first check
WORDS = sorted(_field_names() | set(PLANTS) | set(METRICS) | {"absolute", "natural"})

_KEYS = st.sampled_from(WORDS) | utf8_text(max_size=8)

json_scalars = (
    st.none() | st.booleans()
    | st.integers(min_value=-10**6, max_value=10**6)
    | st.integers(min_value=-2**80, max_value=2**80)
    | st.floats(allow_nan=False, allow_infinity=False)
    | st.sampled_from([0, 0.0, -0.0, -1, -1e-300, 1e-300, 1e308, 0.5, 1, 8, 1e9])
    | utf8_text(max_size=12)
    | st.sampled_from(WORDS)
)

json_values = st.recursive(
    json_scalars,
    lambda children: st.lists(children, max_size=4) | st.dictionaries(_KEYS, children, max_size=4),
    max_leaves=12,
)


# -- (a) one field replaced or removed -----------------------------------------------------

def _outcome(data):
    try:
        return parse_spec(data)
    except SpecError as exc:
        assert_well_formed(exc)
        return exc


_SERVO, _HYDRAULIC = "software_servo", "hydraulic_rotary"


@SETTINGS
@given(site=st.sampled_from(MUTATION_SITES), value=json_values, delete=st.booleans())
@example(site=(_SERVO, ("plant", "time_constant")), value=-1, delete=False)
@example(site=(_SERVO, ("tunables",)), value={"velocity_gain": {}}, delete=False)
@example(site=(_SERVO, ("objective", 0)), value={"metric": "radial_error"}, delete=False)
@example(site=(_SERVO, ("objective", 0, "metric")), value="no_such_metric", delete=False)
@example(site=(_SERVO, ("plant", "type")), value="no_such_plant", delete=False)
@example(site=(_SERVO, ("plant", "technique")), value="reference_pulse", delete=False)
@example(site=(_SERVO, ("plant", "blu")), value=None, delete=True)
@example(site=(_SERVO, ("solver",)), value={"multistart": 1, "tol": 1e-9}, delete=False)
@example(site=(_SERVO, ("plant", "type")), value=_HYDRAULIC, delete=False)
@example(site=(_HYDRAULIC, ("plant", "type")), value=_SERVO, delete=False)
@example(site=(_HYDRAULIC, ("plant", "hydraulic_damping")), value=None, delete=True)
@example(site=(_HYDRAULIC, ("plant", "velocity_compensator")), value="lead", delete=False)
@example(site=(_HYDRAULIC, ("plant", "position_compensator")), value="none", delete=False)
@example(site=(_HYDRAULIC, ("tunables", "velocity_compensator.tau1", "initial")), value=-1,
         delete=False)
@example(site=(_HYDRAULIC, ("objective", 0, "goal")), value="maximise", delete=False)
@example(site=(_HYDRAULIC, ("objective", 0, "goal")), value=None, delete=True)
# found by hypothesis: D_m² underflows to 0 (ZeroDivisionError), or overflows
@example(site=(_HYDRAULIC, ("plant", "displacement")), value=1e-300, delete=False)
@example(site=(_HYDRAULIC, ("plant", "displacement")), value=1e200, delete=False)
# a step horizon of 1e306 s is inf samples (OverflowError from math.ceil before)
@example(site=(_SERVO, ("plant", "time_constant")), value=1e306, delete=False)
# found by hypothesis: R_a·B_m overflows to inf in D(s), whose roots the band needs
@example(site=("ward_leonard", ("plant", "armature_resistance")), value=9e306, delete=False)
def test_one_field_changed_gives_a_spec_or_errors_naming_the_input(site, value, delete):
    plant, path = site
    base = PLANT_EXAMPLES[plant]
    doc = deleted(base, path) if delete else replaced(base, path, value)
    outcome = _outcome(doc)  # anything but Spec or SpecError propagates and fails
    if isinstance(outcome, SpecError):
        for pointer, _ in outcome.errors:
            assert_pointer_names_the_input(pointer, doc)
    else:
        assert isinstance(outcome, Spec)
    # the text path (what the CLI reads) agrees with the parsed-dict path
    text_outcome = _outcome(json.dumps(doc))
    if isinstance(outcome, Spec):
        assert text_outcome == outcome
    else:
        assert isinstance(text_outcome, SpecError) and text_outcome.errors == outcome.errors


def test_every_example_path_is_sampled():
    assert ("plant", "time_constant") in EXAMPLE_PATHS
    assert ("objective", 0, "radius") in EXAMPLE_PATHS
    assert ("tunables", "sampling_period", "value") in EXAMPLE_PATHS
    assert (_SERVO, ("plant", "time_constant")) in MUTATION_SITES
    assert (_HYDRAULIC, ("tunables", "velocity_compensator.tau12", "initial")) in MUTATION_SITES
    assert (_HYDRAULIC, ("objective", 0, "goal")) in MUTATION_SITES


def test_every_plant_with_a_bundled_example_is_mutated():
    """A plant's example enrols it in the mutation test; the bundled examples cover these."""
    assert {_SERVO, _HYDRAULIC} <= set(PLANT_EXAMPLES) <= set(PLANTS)


# -- (b) canonical hash ------------------------------------------------------------------

def _default(field) -> Any:
    return field.default_factory() if field.default_factory is not None else field.default


def _minimal(doc: dict) -> dict:
    """``doc`` without the members that only restate a default."""
    doc = copy.deepcopy(doc)
    for name, field in SolverSpec.model_fields.items():
        if doc.get("solver", {}).get(name, _MISSING) == _default(field):
            del doc["solver"][name]
    if doc.get("solver") == {}:
        del doc["solver"]
    for term in doc["objective"]:
        if term.get("weight") == 1:
            del term["weight"]
    return doc


def _default_spellings(doc: dict) -> list[tuple[tuple, Any]]:
    """(path, value) pairs that spell out a default ``doc`` leaves implicit; the values
    come from the models, so new defaults are enrolled without editing this test."""
    spellings = []
    for name, field in SolverSpec.model_fields.items():
        spellings.append((("solver", name), to_json(_default(field))))
    plant = PLANTS[doc["plant"]["type"]].Params
    for name, field in plant.model_fields.items():
        if not field.is_required() and name not in doc["plant"]:
            spellings.append((("plant", name), to_json(_default(field))))
    for tunable, given in doc.get("tunables", {}).items():
        for name, field in TunableSpec.model_fields.items():
            if name not in given:
                spellings.append((("tunables", tunable, name), to_json(_default(field))))
    for i, term in enumerate(doc["objective"]):
        spellings.append((("objective", i, "weight"), 1.0))
        spellings.append((("objective", i, "weight"), 1))
    if "description" not in doc:
        spellings.append((("description",), ""))
    if "constraints" not in doc:
        spellings.append((("constraints",), []))
    for name in ("min", "max"):
        for i, term in enumerate(doc.get("constraints", [])):
            if name not in term:
                spellings.append((("constraints", i, name), None))
    return spellings


def to_json(value: Any) -> Any:
    return json.loads(json.dumps(value))


def with_value(doc: dict, path: tuple, value: Any) -> dict:
    """``doc`` with ``path`` set (objects created on the way)."""
    doc = copy.deepcopy(doc)
    node = doc
    for part in path[:-1]:
        if isinstance(node, dict):
            node = node.setdefault(part, {})
        else:
            node = node[part]
    node[path[-1]] = value
    return doc


def reordered(node: Any, rnd) -> Any:
    """The same JSON with every object's members in a shuffled order."""
    if isinstance(node, dict):
        keys = list(node)
        rnd.shuffle(keys)
        return {k: reordered(node[k], rnd) for k in keys}
    if isinstance(node, list):
        return [reordered(v, rnd) for v in node]
    return node


MINIMAL = _minimal(EXAMPLE)
SPELLINGS = _default_spellings(MINIMAL)
EXAMPLE_HASH = parse_spec(EXAMPLE).sha256()


def test_minimal_spelling_has_the_examples_hash():
    assert MINIMAL != EXAMPLE  # something was removed: solver.multistart, weight
    assert parse_spec(MINIMAL).sha256() == EXAMPLE_HASH


@SETTINGS
@given(chosen=st.lists(st.sampled_from(SPELLINGS), unique_by=lambda s: s[0]),
       rnd=st.randoms(use_true_random=False), as_text=st.booleans())
@example(chosen=[(("solver", "multistart"), 8)], rnd=None, as_text=False)
def test_hash_ignores_key_order_and_spelled_out_defaults(chosen, rnd, as_text):
    doc = MINIMAL
    for path, value in chosen:
        doc = with_value(doc, path, value)
    if rnd is not None:
        doc = reordered(doc, rnd)
    data = json.dumps(doc, indent=1) if as_text else doc
    assert parse_spec(data).sha256() == EXAMPLE_HASH


@pytest.mark.parametrize("path, value", [
    (("solver", "multistart"), 7),
    (("plant", "counter_bits"), 9),
    (("objective", 0, "weight"), 2),
    (("description",), "another description"),
    (("tunables", "position_gain", "initial"), 10),
])
def test_hash_changes_with_a_non_default_value(path, value):
    assert parse_spec(with_value(EXAMPLE, path, value)).sha256() != EXAMPLE_HASH


# -- (c) arbitrary text and bytes ----------------------------------------------------------

def _mutations() -> st.SearchStrategy[bytes]:
    """The example's bytes cut, spliced or overwritten at random places."""
    n = len(EXAMPLE_BYTES)

    @st.composite
    def mutate(draw):
        start = draw(st.integers(0, n))
        end = draw(st.integers(start, min(n, start + 40)))
        insert = draw(st.binary(max_size=6) | st.sampled_from(
            [b"", b"NaN", b"-Infinity", b"1e400", b'"', b",", b"{", b"]", b"\\u", b"\xff", b"\x00"]))
        return EXAMPLE_BYTES[:start] + insert + EXAMPLE_BYTES[end:]

    return mutate()


texts = (utf8_text() | st.binary().map(bytes) | utf8_text().map(str.encode) | _mutations()
         | json_values.map(json.dumps) | json_values.map(lambda v: json.dumps(v).encode()))


@SETTINGS
@given(data=texts)
@example(data=b"")
@example(data="   \n")
@example(data=b"\xef\xbb\xbf{}")  # UTF-8 byte-order mark
@example(data="1" * 5000)  # more digits than Python's int conversion allows
@example(data='{"name": 1e400}')  # overflows to inf without a NaN/Infinity token
@example(data="[" * (MAX_JSON_DEPTH + 2) + "]" * (MAX_JSON_DEPTH + 2))
@example(data="[" * 100_000)
@example(data='{"a": "\\ud800"}')  # lone surrogate
@example(data=b"\x00" * 10)
@example(data=" " * 2_000_000)
def test_arbitrary_text_is_a_spec_or_a_spec_error(data):
    try:
        spec = parse_spec(data)
    except SpecError as exc:
        assert_well_formed(exc)
    else:
        assert isinstance(spec, Spec)


# -- pointer cases that once went wrong --

def test_unknown_tunable_name_with_a_slash_is_escaped():
    doc = with_value(EXAMPLE, ("tunables", "a/b"), {})
    with pytest.raises(SpecError) as info:
        parse_spec(doc)
    assert info.value.errors[0][0] == "/tunables/a~1b"


def test_bad_ipopt_option_value_names_the_option():
    doc = with_value(EXAMPLE, ("solver", "ipopt_options"), {"mu_strategy": ["adaptive"]})
    with pytest.raises(SpecError) as info:
        parse_spec(doc)
    for pointer, _ in info.value.errors:
        assert_pointer_names_the_input(pointer, doc)


def test_key_named_like_the_metric_does_not_confuse_the_pointer():
    doc = with_value(EXAMPLE, ("objective", 0, "radius"), "x")
    doc = with_value(doc, ("objective", 0, "radial_error"), 1)
    with pytest.raises(SpecError) as info:
        parse_spec(doc)
    for pointer, _ in info.value.errors:
        assert_pointer_names_the_input(pointer, doc)


# -- (d) messages in JSON's words -----------------------------------------------------------

#: Python's names for types (and its constants) that a message for a JSON author must not use
PYTHON_WORDS = re.compile(r"\b(NoneType|None|True|False|dict|dictionary|list|tuple|bool|"
                          r"boolean|int|float|str|bytes|Decimal|instance)\b")
#: a JSON string literal in a message (the user's own text, echoed)
JSON_STRING = re.compile(r'"(?:[^"\\]|\\.)*"')


@SETTINGS
@given(site=st.sampled_from(MUTATION_SITES), value=json_values)
@example(site=(_SERVO, ("objective", 0, "weight")), value=None)
@example(site=(_SERVO, ("objective",)), value={"metric": "iae"})
@example(site=(_SERVO, ("plant",)), value=[1])
@example(site=(_SERVO, ("plant", "type")), value=1.5)
@example(site=(_SERVO, ("plant", "type")), value={"True": None})  # a tag echoed as JSON
@example(site=(_SERVO, ("plant", "type")), value="None")  # was echoed as 'None'
@example(site=(_SERVO, ("solver", "expand")), value="yes")
@example(site=(_SERVO, ("solver", "ipopt_options")), value={"mu_init": None, "max_soc": True})
@example(site=(_HYDRAULIC, ("tunables",)), value=[])
# D_m² underflows to 0: the message said "ZeroDivisionError: float division by zero"
@example(site=(_HYDRAULIC, ("plant", "displacement")), value=1.0268611901489461e-199)
def test_messages_name_json_types_never_python_ones(site, value):
    """Whatever value lands on whatever field, a message says null, true/false, number,
    string, array or object: never NoneType, dict, list, bool (issue 14). The user's own
    strings, echoed back as JSON string literals (a tag {"True": null}), are theirs, not
    Python's: they are blanked before the search."""
    plant, path = site
    outcome = _outcome(replaced(PLANT_EXAMPLES[plant], path, value))
    if isinstance(outcome, SpecError):
        for pointer, message in outcome.errors:
            ours = JSON_STRING.sub('""', message)
            assert not PYTHON_WORDS.search(ours), (pointer, message)


@pytest.mark.parametrize("document, given", [
    (None, "null"), (True, "true"), (3, "a number"), ("spec", "a string"), ([], "an array")])
def test_a_spec_that_is_not_an_object_is_named_in_json_words(document, given):
    with pytest.raises(SpecError) as info:
        parse_spec(json.dumps(document))
    assert info.value.errors == [("", f"a spec is a JSON object, not {given}")]


def test_a_utf8_byte_order_mark_is_accepted():
    """Windows editors start UTF-8 files with a BOM; the spec is the same without it."""
    assert parse_spec(b"\xef\xbb\xbf" + EXAMPLE_BYTES) == parse_spec(EXAMPLE_BYTES)
    assert parse_spec("\ufeff" + EXAMPLE_BYTES.decode()) == parse_spec(EXAMPLE_BYTES)
