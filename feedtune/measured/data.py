"""Measured data of one axis: a time series or a frequency response, read from CSV or JSON.

A file holds one data set. Its columns are named with their units, ``name[unit]``:

- a **time series** (a step or any excitation): ``time[s]`` (or ``ms``), ``command[U]`` (the
  drive's input in any unit U, e.g. ``V``, ``A``, ``N·m``) and one of ``position[m]``,
  ``position[rad]``, ``velocity[m/s]``, ``velocity[rad/s]``; sampled uniformly;
- a **frequency response** from the command to the position or velocity:
  ``frequency[Hz]`` (or ``rad/s``) with ``magnitude[OUT/U]`` and ``phase[deg]`` (or
  ``rad``), or ``real[OUT/U]`` and ``imag[OUT/U]``, and optionally ``coherence[1]``. OUT is
  the output's unit (``m``, ``rad``, ``m/s``, ``rad/s``), U the command's: ``m/V`` is a
  position response, ``rad/s/V`` a velocity response.

CSV: one header row with the column names, then one row of numbers per point; lines
starting with ``#`` and blank lines are skipped. JSON: an object with ``units`` (column name
→ unit), one array of numbers per column and optionally a ``description`` string, e.g. ``{"units": {"time": "s", "command": "V",
"position": "m"}, "time": [...], "command": [...], "position": [...]}``. Several files may
describe the same axis (other table positions, loads or excitations).

Every problem is a :class:`DataError` naming file, line and column (1-based; the column
counts characters), e.g. ``run1.csv:14:9: value 'nan' is not a finite number``.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Literal

import numpy as np

#: the largest data file read [bytes] (10⁶ samples of three columns is ≈ 30 MB)
MAX_DATA_BYTES = 64 * 1024 * 1024
#: fewest points in a data set: with fewer than 5, a two-parameter model leaves fewer than
#: 3 residual degrees of freedom and its residual variance (the uncertainty) is meaningless
MIN_POINTS = 5
#: largest deviation of a time step from the mean step, relative to the mean step [1]: the
#: fits discretise with one period; 1e-3 admits times printed to 6 significant digits
SAMPLING_JITTER = 1e-3

#: unit → factor to SI
TIME_UNITS = {"s": 1.0, "ms": 1e-3}
FREQUENCY_UNITS = {"Hz": 2.0 * math.pi, "rad/s": 1.0}
PHASE_UNITS = {"deg": math.pi / 180.0, "rad": 1.0}
POSITION_UNITS = ("m", "rad")
VELOCITY_UNITS = ("m/s", "rad/s")
OUTPUT_UNITS = POSITION_UNITS + VELOCITY_UNITS

TIME_COLUMNS = ("time", "command", "position", "velocity")
FREQUENCY_COLUMNS = ("frequency", "magnitude", "phase", "real", "imag", "coherence")

OutputKind = Literal["position", "velocity"]


class DataError(ValueError):
    """A data file that cannot be used: ``FILE:LINE:COLUMN: message`` (exit status 2)."""

    def __init__(self, path: str, line: int, column: int, message: str):
        self.path, self.line, self.column, self.message = path, line, column, message
        super().__init__(f"{path}:{line}:{column}: {message}")


def output_kind(unit: str) -> OutputKind:
    """``position`` for ``m``/``rad``, ``velocity`` for ``m/s``/``rad/s``."""
    return "position" if unit in POSITION_UNITS else "velocity"


@dataclass(frozen=True, eq=False, kw_only=True)
class AxisData:
    """What every data set of an axis declares besides its numbers (given by keyword).

    Attributes
    ----------
    input_unit : str
        The command's unit as declared (``V``, ``A``, ``N·m``…).
    output_unit : str
        The output's: ``m``, ``rad`` (a position) or ``m/s``, ``rad/s`` (a velocity).
    source : str
        The file it was read from.
    """

    input_unit: str
    output_unit: str
    source: str

    @property
    def output_kind(self) -> OutputKind:
        return output_kind(self.output_unit)


@dataclass(frozen=True, eq=False)
class TimeSeriesData(AxisData):
    """A uniformly sampled response of the axis to its command.

    Attributes
    ----------
    time_s : ndarray
        Sample times [s], strictly increasing, uniform within :data:`SAMPLING_JITTER`.
    command : ndarray
        The drive's input at each sample [``input_unit``].
    output : ndarray
        Position [m or rad] or velocity [m/s or rad/s] at each sample (``output_unit``).
    """

    time_s: np.ndarray
    command: np.ndarray
    output: np.ndarray

    @property
    def sample_period(self) -> float:
        """The mean sampling period [s]."""
        return float((self.time_s[-1] - self.time_s[0]) / (len(self.time_s) - 1))


@dataclass(frozen=True, eq=False)
class FrequencyResponseData(AxisData):
    """A measured frequency response G(jω) from the command to the position or velocity.

    Attributes
    ----------
    frequency_rad_s : ndarray
        ω [rad/s], strictly increasing, > 0.
    response : ndarray of complex
        G(jω) [``output_unit``/``input_unit``].
    coherence : ndarray or None
        γ²(ω) in [0, 1] [1], when the file gives it.
    """

    frequency_rad_s: np.ndarray
    response: np.ndarray
    coherence: np.ndarray | None


MeasuredData = TimeSeriesData | FrequencyResponseData


@dataclass
class _Column:
    """One column as read: its name and unit, its numbers, where each number is."""

    name: str
    unit: str
    values: np.ndarray
    header_at: tuple[int, int]               # (line, column) of its name
    locate: Callable[[int], tuple[int, int]]  # row index → (line, column) of the value
    end_at: tuple[int, int]                   # (line, column) just after the last row


class _Reader:
    """Column checks shared by both formats; ``fail`` raises a :class:`DataError`."""

    def __init__(self, path: str):
        self.path = path

    def fail(self, at: tuple[int, int], message: str):
        raise DataError(self.path, at[0], at[1], message)


def read_data(path: str | Path) -> MeasuredData:
    """Read one data file (``.csv`` or ``.json``, by its suffix).

    Raises
    ------
    DataError
        Naming file, line and column for every kind of bad data: unreadable file, no
        header, a column without unit or with an unknown one, a missing or duplicated
        column, a value that is not a finite number, a row of the wrong length, time or
        frequency not strictly increasing, non-uniform sampling, fewer than
        :data:`MIN_POINTS` points, coherence outside [0, 1].
    """
    label = str(path)
    reader = _Reader(label)
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".csv", ".json"):
        reader.fail((1, 1), f"unknown data format {path.suffix!r}: give a .csv or .json file")
    try:
        with open(path, "rb") as handle:
            raw = handle.read(MAX_DATA_BYTES + 1)
    except FileNotFoundError:
        reader.fail((1, 1), "no such file")
    except IsADirectoryError:
        reader.fail((1, 1), "is a directory, not a data file")
    except OSError as exc:
        reader.fail((1, 1), f"cannot read: {exc.strerror or exc}")
    if len(raw) > MAX_DATA_BYTES:
        reader.fail((1, 1), f"file is larger than the limit of {MAX_DATA_BYTES} bytes")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw[:exc.start].count(b"\n") + 1
        reader.fail((line, 1), "not UTF-8 text")
    columns = _csv_columns(reader, text) if suffix == ".csv" else _json_columns(reader, text)
    return _data_set(reader, columns)


def read_all(paths) -> list[MeasuredData]:
    """:func:`read_data` of every path, in order (the first bad file raises)."""
    return [read_data(p) for p in paths]


def to_csv(data: MeasuredData, comment: str = "") -> bytes:
    """``data`` as the CSV :func:`read_data` reads (SI units; a frequency response as
    frequency[Hz], real and imag), every number to 17 significant digits (read back within an ulp)."""
    lines = [f"# {line}" for line in comment.splitlines()]
    if isinstance(data, TimeSeriesData):
        name = output_kind(data.output_unit)
        lines.append(f"time[s],command[{data.input_unit}],{name}[{data.output_unit}]")
        rows = np.column_stack([data.time_s, data.command, data.output])
    else:
        unit = f"{data.output_unit}/{data.input_unit}"
        lines.append(f"frequency[Hz],real[{unit}],imag[{unit}]"
                     + (",coherence[1]" if data.coherence is not None else ""))
        parts = [data.frequency_rad_s / (2.0 * math.pi), data.response.real, data.response.imag]
        rows = np.column_stack(parts + ([data.coherence] if data.coherence is not None else []))
    lines.extend(",".join(f"{v:.17g}" for v in row) for row in rows)
    return ("\n".join(lines) + "\n").encode()


# ---------------------------------------------------------------- CSV


def _split_name(reader: _Reader, field: str, at: tuple[int, int]) -> tuple[str, str]:
    """``name[unit]`` → (name, unit)."""
    field = field.strip()
    if "[" not in field:
        reader.fail(at, f"column {field!r} has no unit: write it as {field}[unit]")
    name, _, rest = field.partition("[")
    if not rest.endswith("]") or not rest[:-1].strip():
        reader.fail(at, f"column {field!r}: write the unit in brackets, name[unit]")
    return name.strip().lower(), rest[:-1].strip()


def _csv_columns(reader: _Reader, text: str) -> list[_Column]:
    lines = text.splitlines()
    rows: list[int] = []           # 0-based line index of every data row
    header_index = None
    for index, line in enumerate(lines):
        stripped = line.strip()
        if not stripped or stripped.startswith("#"):
            continue
        if header_index is None:
            header_index = index
        else:
            rows.append(index)
    if header_index is None:
        reader.fail((len(lines) + 1, 1), "no header row: the first line that is not a "
                                          "comment names the columns, e.g. time[s],command[V],"
                                          "position[m]")

    def starts(line: str) -> list[int]:
        """1-based character column where each comma-separated field's text starts."""
        out, offset = [], 0
        for field in line.split(","):
            out.append(offset + len(field) - len(field.lstrip()) + 1)
            offset += len(field) + 1
        return out

    header = lines[header_index].split(",")
    header_starts = starts(lines[header_index])
    width = len(header)
    table = np.empty((len(rows), width))
    for r, index in enumerate(rows):
        fields = lines[index].split(",")
        if len(fields) != width:  # at the first extra field, or the end of a short row
            at = starts(lines[index])[width] if len(fields) > width else len(lines[index]) + 1
            reader.fail((index + 1, at), f"row has {len(fields)} fields, the header {width}")
        for c, field in enumerate(fields):
            try:
                table[r, c] = float(field)
            except ValueError:
                reader.fail((index + 1, starts(lines[index])[c]),
                            f"value {field.strip()!r} is not a number")
    end = (rows[-1] + 2 if rows else header_index + 2, 1)
    columns = []
    for c, field in enumerate(header):
        at = (header_index + 1, header_starts[c])
        name, unit = _split_name(reader, field, at)
        columns.append(_Column(
            name, unit, table[:, c], at,
            lambda r, c=c: (rows[r] + 1, starts(lines[rows[r]])[c]), end))
    return columns


# ---------------------------------------------------------------- JSON


def _line_column(text: str, offset: int) -> tuple[int, int]:
    line = text.count("\n", 0, offset) + 1
    return line, offset - (text.rfind("\n", 0, offset) + 1) + 1


def _skip_space(text: str, i: int) -> int:
    while i < len(text) and text[i] in " \t\r\n":
        i += 1
    return i


def _offsets(text: str) -> dict[str, tuple[int, list[int]]]:
    """Top-level key → (offset of the key, offsets of its array's elements) of a JSON
    object known to be valid (positions are only needed to report an error)."""
    decoder = json.JSONDecoder(parse_constant=float)
    out: dict[str, tuple[int, list[int]]] = {}
    i = _skip_space(text, 0) + 1  # past '{'
    while True:
        i = _skip_space(text, i)
        if text[i] == "}":
            return out
        key_at = i
        key, i = json.decoder.scanstring(text, i + 1)
        i = _skip_space(text, _skip_space(text, i) + 1)  # past ':'
        elements: list[int] = []
        if text[i] == "[":
            i = _skip_space(text, i + 1)
            while text[i] != "]":
                elements.append(i)
                _, i = decoder.raw_decode(text, i)
                i = _skip_space(text, i)
                if text[i] == ",":
                    i = _skip_space(text, i + 1)
            i += 1
        else:
            _, i = decoder.raw_decode(text, i)
        out.setdefault(key, (key_at, elements))
        i = _skip_space(text, i)
        if text[i] == ",":
            i += 1


def _json_columns(reader: _Reader, text: str) -> list[_Column]:
    def unique(pairs):
        seen = {}
        for key, value in pairs:
            if key in seen:
                raise ValueError(f"duplicate key {key!r}")
            seen[key] = value
        return seen

    try:
        # NaN and Infinity are read, then refused where they stand (_data_set)
        document = json.loads(text, object_pairs_hook=unique)
    except json.JSONDecodeError as exc:
        reader.fail((exc.lineno, exc.colno), f"invalid JSON: {exc.msg}")
    except (ValueError, RecursionError) as exc:
        reader.fail((1, 1), f"invalid JSON: {exc}")
    if not isinstance(document, dict):
        reader.fail((1, 1), "the JSON document must be an object with 'units' and one array "
                            "per column")
    positions = _offsets(text)

    def where(key: str) -> tuple[int, int]:
        return _line_column(text, positions[key][0])

    units = document.get("units")
    if not isinstance(units, dict):
        reader.fail(where("units") if "units" in document else (1, 1),
                    "'units' is missing: give an object naming each column's unit, e.g. "
                    "{\"time\": \"s\", \"command\": \"V\", \"position\": \"m\"}")
    columns = []
    end = _line_column(text, len(text.rstrip()))
    description = document.get("description")
    if description is not None and not isinstance(description, str):
        reader.fail(where("description"), "'description' must be a string")
    for key, values in document.items():
        if key in ("units", "description"):
            continue
        unit = units.get(key)
        if not isinstance(unit, str) or not unit.strip():
            reader.fail(where("units") if key not in units else
                        _line_column(text, text.find(json.dumps(key), positions["units"][0])),
                        f"column {key!r} has no unit in 'units'")
        if not isinstance(values, list):
            reader.fail(where(key), f"{key!r} must be an array of numbers")
        array = np.empty(len(values))
        for r, value in enumerate(values):
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                reader.fail(_line_column(text, positions[key][1][r]),
                            f"value {json.dumps(value)[:40]} is not a number")
            array[r] = value
        columns.append(_Column(
            key.strip().lower(), unit.strip(), array, where(key),
            lambda r, key=key: _line_column(text, positions[key][1][r]), end))
    for key in units:
        if key not in document:
            reader.fail(where("units"), f"'units' names {key!r}, which has no array")
    return columns


# ---------------------------------------------------------------- checks


def _data_set(reader: _Reader, columns: list[_Column]) -> MeasuredData:
    by_name: dict[str, _Column] = {}
    for column in columns:
        if column.name in by_name:
            reader.fail(column.header_at, f"column {column.name!r} appears twice")
        if column.name not in TIME_COLUMNS + FREQUENCY_COLUMNS:
            reader.fail(column.header_at,
                        f"unknown column {column.name!r}: a time series has "
                        f"{', '.join(TIME_COLUMNS)}; a frequency response "
                        f"{', '.join(FREQUENCY_COLUMNS)}")
        by_name[column.name] = column
    first = columns[0].header_at if columns else (1, 1)
    if "time" in by_name and "frequency" in by_name:
        reader.fail(by_name["frequency"].header_at,
                    "a file holds a time series (time) or a frequency response (frequency), "
                    "not both")
    if "time" not in by_name and "frequency" not in by_name:
        reader.fail(first, "missing column: time[s] (a time series) or frequency[Hz] "
                           "(a frequency response)")
    kind = "time" if "time" in by_name else "frequency"
    allowed = TIME_COLUMNS if kind == "time" else FREQUENCY_COLUMNS
    for column in columns:
        if column.name not in allowed:
            reader.fail(column.header_at, f"column {column.name!r} does not belong in a "
                                          f"{'time series' if kind == 'time' else 'frequency response'}")
    for column in columns:
        bad = np.flatnonzero(~np.isfinite(column.values))
        if bad.size:
            reader.fail(column.locate(int(bad[0])),
                        f"value {column.values[bad[0]]:g} in {column.name!r} is not a finite number")
    count = len(columns[0].values)
    if count < MIN_POINTS:
        reader.fail(columns[0].end_at, f"{count} points; a data set needs at least {MIN_POINTS}")
    return _time_series(reader, by_name) if kind == "time" else _frequency(reader, by_name)


def _increasing(reader: _Reader, column: _Column, what: str) -> None:
    steps = np.diff(column.values)
    bad = np.flatnonzero(steps <= 0)
    if bad.size:
        r = int(bad[0]) + 1
        reader.fail(column.locate(r), f"{what} is not strictly increasing: "
                                      f"{column.values[r]:g} after {column.values[r - 1]:g}")


def _unit(reader: _Reader, column: _Column, allowed) -> str:
    if column.unit not in allowed:
        reader.fail(column.header_at, f"unit {column.unit!r} of {column.name!r}: use "
                                      f"{' or '.join(allowed)} (SI)")
    return column.unit


def _time_series(reader: _Reader, by_name: dict[str, _Column]) -> TimeSeriesData:
    time = by_name["time"]
    scale = TIME_UNITS[_unit(reader, time, tuple(TIME_UNITS))]
    _increasing(reader, time, "time")
    if "command" not in by_name:
        reader.fail(time.header_at, "missing column command[UNIT], the drive's input")
    outputs = [by_name[n] for n in ("position", "velocity") if n in by_name]
    if len(outputs) != 1:
        reader.fail(outputs[1].header_at if outputs else time.header_at,
                    "give one output column: position[m or rad] or velocity[m/s or rad/s]"
                    if outputs else "missing column position[m or rad] or "
                                    "velocity[m/s or rad/s]")
    output = outputs[0]
    _unit(reader, output, POSITION_UNITS if output.name == "position" else VELOCITY_UNITS)
    steps = np.diff(time.values)
    mean = (time.values[-1] - time.values[0]) / (len(time.values) - 1)
    bad = np.flatnonzero(np.abs(steps - mean) > SAMPLING_JITTER * mean)
    if bad.size:
        r = int(bad[0]) + 1
        reader.fail(time.locate(r), f"time step {steps[r - 1]:g} {time.unit} differs from the "
                                    f"mean step {mean:g} {time.unit} by more than {SAMPLING_JITTER:g} of it: resample "
                                    "uniformly")
    command = by_name["command"]
    return TimeSeriesData(time.values * scale, command.values, output.values,
                          input_unit=command.unit, output_unit=output.unit, source=reader.path)


def _response_unit(reader: _Reader, column: _Column) -> tuple[str, str]:
    """``OUT/IN`` → (OUT, IN), OUT one of :data:`OUTPUT_UNITS`."""
    out, _, inp = column.unit.rpartition("/")
    if out not in OUTPUT_UNITS or not inp.strip():
        reader.fail(column.header_at,
                    f"unit {column.unit!r} of {column.name!r}: write the response's unit as "
                    f"OUTPUT/INPUT with OUTPUT one of {', '.join(OUTPUT_UNITS)}, e.g. m/V "
                    "(a position response) or rad/s/V (a velocity response)")
    return out, inp.strip()


def _frequency(reader: _Reader, by_name: dict[str, _Column]) -> FrequencyResponseData:
    frequency = by_name["frequency"]
    scale = FREQUENCY_UNITS[_unit(reader, frequency, tuple(FREQUENCY_UNITS))]
    nonpositive = np.flatnonzero(frequency.values <= 0)
    if nonpositive.size:
        reader.fail(frequency.locate(int(nonpositive[0])), "frequency must be greater than 0")
    _increasing(reader, frequency, "frequency")
    polar = [n for n in ("magnitude", "phase") if n in by_name]
    cartesian = [n for n in ("real", "imag") if n in by_name]
    if polar and cartesian:
        reader.fail(by_name[cartesian[0]].header_at,
                    "give magnitude and phase, or real and imag, not both")
    for name in ("real", "imag") if cartesian else ("magnitude", "phase"):
        if name not in by_name:
            reader.fail(frequency.header_at, f"missing column {name!r}: a frequency response "
                                             "gives magnitude[OUT/IN] and phase[deg], or "
                                             "real[OUT/IN] and imag[OUT/IN]")
    if polar:
        magnitude, phase = by_name["magnitude"], by_name["phase"]
        out, inp = _response_unit(reader, magnitude)
        negative = np.flatnonzero(magnitude.values < 0)
        if negative.size:
            reader.fail(magnitude.locate(int(negative[0])), "magnitude must not be negative")
        angle = PHASE_UNITS[_unit(reader, phase, tuple(PHASE_UNITS))]
        response = magnitude.values * np.exp(1j * angle * phase.values)
    else:
        real, imag = by_name["real"], by_name["imag"]
        out, inp = _response_unit(reader, real)
        if imag.unit != real.unit:
            reader.fail(imag.header_at, f"unit {imag.unit!r} of 'imag' differs from "
                                        f"{real.unit!r} of 'real'")
        response = real.values + 1j * imag.values
    coherence = None
    if "coherence" in by_name:
        column = by_name["coherence"]
        _unit(reader, column, ("1",))
        outside = np.flatnonzero((column.values < 0) | (column.values > 1))
        if outside.size:
            reader.fail(column.locate(int(outside[0])), "coherence must be within [0, 1]")
        coherence = column.values
    return FrequencyResponseData(frequency.values * scale, response, coherence,
                                 input_unit=inp, output_unit=out, source=reader.path)
