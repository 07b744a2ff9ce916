"""Hypothesis on specs of measured frequency responses (feedtune/measured/datadriven_spec.py):
any JSON value in any field is a spec or a SpecError naming JSON pointers, never another
exception; valid data parse to the numbers given, Hz converted to rad/s."""

from __future__ import annotations

import copy
import math

import numpy as np
from hypothesis import given, settings, strategies as st

from hypothesis_text import utf8_text

from feedtune.measured.datadriven_spec import DataDrivenSpec
from feedtune.plants.frequency_response_data import FrequencyResponseData
from feedtune.schema.spec import SpecError, parse_spec

BASE = {
    "name": "frd",
    "plant": {"type": "frequency_response_data", "input_unit": "V", "output_unit": "m",
              "controller": "pi",
              "sets": [{"name": "a", "frequency_unit": "Hz",
                        "frequency": [1.0, 2.0, 3.0, 4.0, 5.0],
                        "real": [1.0, 0.5, 0.2, 0.1, 0.05],
                        "imag": [-1.0, -0.5, -0.3, -0.2, -0.1]}]},
    "tunables": {"controller.kp": {"min": 0.1, "max": 10}},
    "objective": [{"metric": "bandwidth", "goal": "maximize"}],
    "constraints": [{"metric": "m_peak", "max": 1.3}],
}

JSON = st.recursive(
    st.none() | st.booleans() | st.floats(allow_nan=False, allow_infinity=False)
    | st.integers(-10**6, 10**6) | utf8_text(max_size=8),
    lambda children: st.lists(children, max_size=4)
    | st.dictionaries(utf8_text(max_size=6), children, max_size=4),
    max_leaves=12)

PATHS = [("name",), ("plant",), ("plant", "sets"), ("plant", "sets", 0),
         ("plant", "sets", 0, "frequency"), ("plant", "sets", 0, "frequency_unit"),
         ("plant", "sets", 0, "real"), ("plant", "sets", 0, "imag"),
         ("plant", "sets", 0, "name"), ("plant", "controller"), ("plant", "integrators"),
         ("plant", "unstable_poles"), ("plant", "filter_time_constant"),
         ("plant", "output_unit"), ("tunables",), ("tunables", "controller.kp"),
         ("objective",), ("objective", 0), ("constraints", 0, "max"), ("solver",),
         ("plant", "sets", 0, "frequency", 2), ("plant", "extra")]


def _put(document, path, value):
    node = document
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value


@settings(max_examples=300, deadline=None)
@given(st.sampled_from(PATHS), JSON)
def test_any_value_anywhere_is_a_spec_or_pointed_errors(path, value):
    document = copy.deepcopy(BASE)
    _put(document, path, value)
    try:
        spec = parse_spec(document)
    except SpecError as exc:
        assert exc.errors
        for pointer, message in exc.errors:
            assert pointer == "" or pointer.startswith("/"), pointer
            assert message
        return
    assert isinstance(spec, DataDrivenSpec)


@settings(max_examples=100, deadline=None)
@given(st.lists(st.floats(1e-3, 1e5), min_size=5, max_size=40, unique=True),
       st.sampled_from(["Hz", "rad/s"]), st.data())
def test_valid_data_parse_to_their_numbers(frequencies, unit, data):
    frequencies = sorted(frequencies)
    n = len(frequencies)
    numbers = st.floats(-1e6, 1e6, allow_nan=False).filter(lambda v: abs(v) > 1e-9)
    real = data.draw(st.lists(numbers, min_size=n, max_size=n))
    imag = data.draw(st.lists(numbers, min_size=n, max_size=n))
    document = copy.deepcopy(BASE)
    document["plant"]["sets"][0].update(frequency_unit=unit, frequency=frequencies,
                                        real=real, imag=imag)
    spec = parse_spec(document)
    [measured] = FrequencyResponseData(spec.plant).sets()
    scale = 2 * math.pi if unit == "Hz" else 1.0
    np.testing.assert_array_equal(measured.omega, np.array(frequencies) * scale)
    np.testing.assert_array_equal(measured.response, np.array(real) + 1j * np.array(imag))
