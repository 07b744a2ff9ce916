"""The measured-data readers: what they read, and every kind of bad data named by file, line
and column (issue 17 item 4)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hypothesis_text import utf8_text

from feedtune.measured.data import (MIN_POINTS, DataError, FrequencyResponseData, TimeSeriesData,
                                    read_data, to_csv)

REPO = Path(__file__).resolve().parents[3]
SAMPLES = "\n".join(f"{k * 0.001:g},1,{k * 1e-4:g}" for k in range(8))
TIME_CSV = "time[s],command[V],position[m]\n" + SAMPLES + "\n"
FREQ_CSV = ("frequency[Hz],magnitude[m/V],phase[deg],coherence[1]\n"
            + "\n".join(f"{f},{1 / f},-90,0.9" for f in (1, 2, 4, 8, 16, 32)) + "\n")


def write(tmp_path: Path, text: str, name: str = "d.csv") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def error(tmp_path: Path, text: str, name: str = "d.csv") -> DataError:
    path = write(tmp_path, text, name)
    with pytest.raises(DataError) as caught:
        read_data(path)
    assert str(caught.value).startswith(f"{path}:{caught.value.line}:{caught.value.column}: ")
    return caught.value


def test_time_series_csv(tmp_path):
    d = read_data(write(tmp_path, "# a comment\n\n" + TIME_CSV))
    assert isinstance(d, TimeSeriesData)
    assert d.output_kind == "position" and d.output_unit == "m" and d.input_unit == "V"
    assert d.sample_period == pytest.approx(1e-3, rel=1e-12)
    np.testing.assert_array_equal(d.output, [float(f"{k * 1e-4:g}") for k in range(8)])


def test_milliseconds_are_converted(tmp_path):
    text = TIME_CSV.replace("time[s]", "time[ms]")
    d = read_data(write(tmp_path, text))
    assert d.sample_period == pytest.approx(1e-6, rel=1e-12)


def test_frequency_response_csv_hz_degrees(tmp_path):
    d = read_data(write(tmp_path, FREQ_CSV))
    assert isinstance(d, FrequencyResponseData)
    np.testing.assert_allclose(d.frequency_rad_s, 2 * np.pi * np.array([1, 2, 4, 8, 16, 32]),
                               rtol=1e-15)
    # magnitude 1/f at −90°: −j/f, to the rounding of cos(π/2) ≈ 6e-17
    np.testing.assert_allclose(d.response, -1j / np.array([1, 2, 4, 8, 16, 32]), atol=1e-16)
    assert d.output_kind == "position" and d.input_unit == "V"
    np.testing.assert_array_equal(d.coherence, 0.9)


def test_velocity_response_unit(tmp_path):
    d = read_data(write(tmp_path, FREQ_CSV.replace("m/V", "rad/s/V")))
    assert d.output_unit == "rad/s" and d.output_kind == "velocity" and d.input_unit == "V"


def test_json_time_series(tmp_path):
    doc = {"description": "run 1", "units": {"time": "s", "command": "V", "velocity": "m/s"},
           "time": [0, 1, 2, 3, 4, 5], "command": [1] * 6, "velocity": [0, 1, 2, 3, 4, 5]}
    d = read_data(write(tmp_path, json.dumps(doc), "d.json"))
    assert d.output_kind == "velocity" and d.sample_period == 1.0


def test_bundled_example_data_read():
    for path in sorted((REPO / "examples" / "data").glob("*.*")):
        if path.suffix in (".csv", ".json"):
            read_data(path)


# ---------------------------------------------------------------- every error, located


@pytest.mark.parametrize("text, line, column, words", [
    # missing column: no output
    ("time[s],command[V]\n" + "\n".join(f"{k},1" for k in range(6)), 1, 1, "missing column"),
    # missing column: no command
    ("time[s],position[m]\n" + "\n".join(f"{k},1" for k in range(6)), 1, 1, "command"),
    # no unit
    (TIME_CSV.replace("command[V]", "command"), 1, 9, "has no unit"),
    # a unit that is not SI
    (TIME_CSV.replace("position[m]", "position[mm]"), 1, 20, "use m or rad"),
    # NaN, located at its field
    (TIME_CSV.replace("0.0003\n", "nan\n"), 5, 9, "not a finite number"),
    # infinity
    (TIME_CSV.replace("0.0003\n", "inf\n"), 5, 9, "not a finite number"),
    # text
    (TIME_CSV.replace("0.0003\n", "abc\n"), 5, 9, "not a number"),
    # non-monotone time
    (TIME_CSV.replace("0.003,", "0.001,"), 5, 1, "not strictly increasing"),
    # non-uniform sampling
    (TIME_CSV.replace("0.003,", "0.0031,"), 5, 1, "resample uniformly"),
    # a short row
    (TIME_CSV.replace("0.003,1,0.0003", "0.003,1"), 5, 8, "2 fields"),
    # a long row, at its extra field
    (TIME_CSV.replace("0.003,1,0.0003", "0.003,1,0.0003,7"), 5, 16, "4 fields"),
    # too few points: reported after the last row
    ("time[s],command[V],position[m]\n0,1,0\n1,1,1\n", 4, 1, f"at least {MIN_POINTS}"),
    # no header
    ("# only a comment\n", 2, 1, "no header"),
    # unknown column
    (TIME_CSV.replace("command[V]", "current[A]"), 1, 9, "unknown column"),
    # both outputs
    ("time[s],command[V],position[m],velocity[m/s]\n"
     + "\n".join(f"{k},1,1,1" for k in range(6)), 1, 32, "one output"),
    # time and frequency
    ("time[s],frequency[Hz]\n" + "\n".join(f"{k},1" for k in range(6)), 1, 9, "not both"),
])
def test_bad_time_series(tmp_path, text, line, column, words):
    exc = error(tmp_path, text)
    assert (exc.line, exc.column) == (line, column), str(exc)
    assert words in exc.message


@pytest.mark.parametrize("text, line, column, words", [
    # non-monotone frequency
    (FREQ_CSV.replace("8,0.125", "3,0.125"), 5, 1, "not strictly increasing"),
    # zero frequency
    (FREQ_CSV.replace("1,1.0,", "0,1.0,"), 2, 1, "greater than 0"),
    # magnitude without phase
    ("frequency[Hz],magnitude[m/V]\n" + "\n".join(f"{f},1" for f in range(1, 7)), 1, 1,
     "missing column 'phase'"),
    # a response unit that is not OUTPUT/INPUT
    (FREQ_CSV.replace("magnitude[m/V]", "magnitude[1]"), 1, 15, "OUTPUT/INPUT"),
    # a phase unit
    (FREQ_CSV.replace("phase[deg]", "phase[grad]"), 1, 30, "deg or rad"),
    # coherence above 1
    (FREQ_CSV.replace("4,0.25,-90,0.9", "4,0.25,-90,1.5"), 4, 12, "within [0, 1]"),
    # negative magnitude
    (FREQ_CSV.replace("2,0.5,", "2,-0.5,"), 3, 3, "must not be negative"),
    # NaN phase
    (FREQ_CSV.replace("16,0.0625,-90", "16,0.0625,nan"), 6, 11, "not a finite number"),
])
def test_bad_frequency_response(tmp_path, text, line, column, words):
    exc = error(tmp_path, text)
    assert (exc.line, exc.column) == (line, column), str(exc)
    assert words in exc.message


def test_real_and_imag_need_one_unit(tmp_path):
    text = "frequency[rad/s],real[m/V],imag[m/A]\n" + "\n".join(f"{f},1,1" for f in range(1, 7))
    exc = error(tmp_path, text)
    assert (exc.line, exc.column, "differs") == (1, 28, "differs") and "differs" in exc.message


@pytest.mark.parametrize("document, line, column, words", [
    ('{"units": {"time": "s", "command": "V", "position": "m"},\n"time": [0, 1, 2, 3, 4],\n'
     '"command": [1, 1, 1, 1, 1],\n"position": [0, 1, NaN, 3, 4]}', 4, 20, "not a finite"),
    ('{"units": {"time": "s", "command": "V"},\n"time": [0, 1, 2, 3, 4],\n'
     '"command": [1, 1, 1, 1, 1],\n"position": [0, 1, 2, 3, 4]}', 1, 2, "no unit"),
    ('{"time": [0, 1, 2, 3, 4]}', 1, 1, "'units' is missing"),
    ('{"units": {"time": "s", "command": "V", "position": "m"},\n"time": [0, 1, 2, 3, 4],\n'
     '"command": [1, 1, "x", 1, 1],\n"position": [0, 1, 2, 3, 4]}', 3, 19, "not a number"),
    ('{"units": {}, "time": [0, 1,', 1, 29, "invalid JSON"),
    ('{"units": {"time": "s"}, "time": [1], "time": [2]}', 1, 1, "duplicate key"),
    ('[1, 2]', 1, 1, "must be an object"),
])
def test_bad_json(tmp_path, document, line, column, words):
    exc = error(tmp_path, document, "d.json")
    assert (exc.line, exc.column) == (line, column), str(exc)
    assert words in exc.message


def test_unreadable_files(tmp_path):
    with pytest.raises(DataError, match=r":1:1: no such file"):
        read_data(tmp_path / "missing.csv")
    with pytest.raises(DataError, match=r"unknown data format"):
        read_data(write(tmp_path, TIME_CSV, "d.txt"))
    (tmp_path / "b.csv").write_bytes(b"time[s],command[V],position[m]\n0,1,\xff\n")
    with pytest.raises(DataError, match=r"b.csv:2:1: not UTF-8"):
        read_data(tmp_path / "b.csv")


# ---------------------------------------------------------------- hypothesis

finite = st.floats(min_value=-1e12, max_value=1e12, allow_nan=False, allow_infinity=False)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(count=st.integers(MIN_POINTS, 40), period=st.floats(1e-6, 10.0),
       start=st.floats(-1e3, 1e3), data=st.data(), velocity=st.booleans())
def test_time_series_round_trip(tmp_path, count, period, start, data, velocity):
    """What :func:`to_csv` writes reads back to the same numbers (17 digits: exact values,
    the times within an ulp of their magnitude)."""
    command = np.array(data.draw(st.lists(finite, min_size=count, max_size=count)))
    output = np.array(data.draw(st.lists(finite, min_size=count, max_size=count)))
    time = start + period * np.arange(count)
    original = TimeSeriesData(time, command, output, input_unit="V",
                              output_unit="m/s" if velocity else "m", source="x")
    path = tmp_path / "round.csv"
    path.write_bytes(to_csv(original, "generated"))
    back = read_data(path)
    np.testing.assert_array_equal(back.command, command)
    np.testing.assert_array_equal(back.output, output)
    np.testing.assert_array_equal(back.time_s, time)
    assert back.output_unit == original.output_unit


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(frequencies=st.lists(st.floats(1e-3, 1e6), min_size=MIN_POINTS, max_size=30,
                            unique=True),
       data=st.data())
def test_frequency_response_round_trip(tmp_path, frequencies, data):
    omega = np.sort(np.array(frequencies))
    if np.any(np.diff(omega) <= 1e-12 * omega[1:]):  # two that print alike in Hz
        return
    count = len(omega)
    re = np.array(data.draw(st.lists(finite, min_size=count, max_size=count)))
    im = np.array(data.draw(st.lists(finite, min_size=count, max_size=count)))
    original = FrequencyResponseData(omega, re + 1j * im, None, input_unit="V", output_unit="rad",
                                     source="x")
    path = tmp_path / "round.csv"
    path.write_bytes(to_csv(original))
    back = read_data(path)
    np.testing.assert_array_equal(back.response, original.response)
    # ω → Hz → ω: two roundings of 2π, within 4 ulp
    np.testing.assert_allclose(back.frequency_rad_s, omega, rtol=4 * np.finfo(float).eps)


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(text=st.text(alphabet=st.sampled_from(list("0123456789.,-+e\n#[]/ abtimecsdpoV")),
                    max_size=300),
       suffix=st.sampled_from([".csv", ".json"]))
def test_any_text_is_read_or_refused_with_a_location(tmp_path, text, suffix):
    """No input makes the reader fail other than with a located DataError, and a data set
    it returns holds only finite numbers."""
    path = tmp_path / f"fuzz{suffix}"
    path.write_text(text)
    try:
        d = read_data(path)
    except DataError as exc:
        assert exc.line >= 1 and exc.column >= 1
        return
    values = [d.time_s, d.command, d.output] if isinstance(d, TimeSeriesData) else \
        [d.frequency_rad_s, d.response]
    assert all(np.all(np.isfinite(v)) for v in values)


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(document=st.recursive(
    st.none() | st.booleans() | st.floats(allow_nan=True) | utf8_text(max_size=5),
    lambda children: st.lists(children, max_size=6)
    | st.dictionaries(st.sampled_from(["units", "time", "command", "position", "frequency",
                                       "real", "imag", "s", "V", "m"]), children, max_size=5),
    max_leaves=30))
def test_any_json_is_read_or_refused_with_a_location(tmp_path, document):
    path = tmp_path / "fuzz.json"
    path.write_text(json.dumps(document))
    try:
        read_data(path)
    except DataError as exc:
        assert exc.line >= 1 and exc.column >= 1
        assert not math.isnan(exc.line)
