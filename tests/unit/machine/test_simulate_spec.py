"""The machine spec is untrusted input (feedtune/machine/spec.py): any JSON is a
MachineSpec or a SpecError naming each bad field by JSON pointer, never a traceback."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hypothesis_text import utf8_text

from feedtune.machine.spec import MachineSpec, parse_machine
from feedtune.schema.spec import SpecError

REPO = Path(__file__).resolve().parents[3]
EXAMPLE = json.loads((REPO / "examples" / "machine" / "two-axes.json").read_text())

TIAN = json.loads((REPO / "examples" / "tian-vf-pulse.json").read_text())
TIAN_AXIS = {"plant": TIAN["plant"], "tunables": TIAN["tunables"]}

json_values = st.recursive(
    st.none() | st.booleans() | st.integers(-10**6, 10**6)
    | st.floats(allow_nan=False, allow_infinity=False) | utf8_text(max_size=8),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(utf8_text(max_size=6), inner,
                                                                max_size=3),
    max_leaves=6)


def _paths(node, prefix=()):
    yield prefix
    if isinstance(node, dict):
        for key, value in node.items():
            yield from _paths(value, prefix + (key,))


PATHS = [p for p in _paths(EXAMPLE) if p]


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(where=st.sampled_from(PATHS), value=json_values, delete=st.booleans())
def test_any_change_is_a_spec_or_pointed_errors(where, value, delete):
    raw = copy.deepcopy(EXAMPLE)
    node = raw
    for key in where[:-1]:
        node = node[key]
    if delete:
        del node[where[-1]]
    else:
        node[where[-1]] = value
    try:
        spec = parse_machine(raw)
    except SpecError as exc:
        assert exc.errors
        for pointer, message in exc.errors:
            assert pointer == "" or pointer.startswith("/")
            assert message
        return
    assert isinstance(spec, MachineSpec)


@pytest.mark.parametrize("change, pointer", [
    (lambda r: r["axes"]["x"]["tunables"].update(bogus={"value": 1}), "/axes/x/tunables/bogus"),
    (lambda r: r.update(program="part.ngc"), "/program"),
    (lambda r: r["axes"].update(w=r["axes"]["x"]), "/axes/w"),
    (lambda r: r["interpolator"].update(period=0.0015), "/interpolator/period"),
    (lambda r: r["axes"].update(y=TIAN_AXIS), "/axes/y/plant"),
    (lambda r: r.update(feed_override={"min": 0.1, "max": 2}, tuning={}), ""),
    (lambda r: r["interpolator"].update(in_position=0.0), "/interpolator/in_position"),
    (lambda r: r["interpolator"].update(max_normal_acceleration=-1.0),
     "/interpolator/max_normal_acceleration"),
    (lambda r: (r["interpolator"].update(in_position=1e-6),
                r.update(cross_coupling={"gain": 1.0})), "/interpolator/in_position"),
])
def test_named_errors(change, pointer):
    """Each mistake is refused at its own pointer: an unknown tunable, a file named in the
    spec, a fourth axis, an interpolation period that is not a whole number of samples,
    a plant with no linear loop, a free feed without a tolerance (the spec as a whole), an
    in-position band of zero, a negative normal acceleration, an in-position wait with
    Koren's cross-coupled controller (its loop follows the path: the wait's sum of pieces
    does not hold)."""
    raw = copy.deepcopy(EXAMPLE)
    change(raw)
    with pytest.raises(SpecError) as caught:
        parse_machine(raw)
    assert pointer in [p for p, _ in caught.value.errors], caught.value.errors
