"""The command line through its real entry points (``feedtune.__main__.run`` in this
process, tests/feedtune_cli.py; ``python -m feedtune`` and the ``feedtune`` console script
where a process of its own is the point): exit statuses, stdout carrying only JSON, errors
naming the field by JSON pointer, and the listing commands."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import typing
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

import feedtune
from feedtune.measured.datadriven_spec import DATA_METRICS
from feedtune.objectives import METRICS
from feedtune.plants import DATA_PLANTS, PLANTS
from feedtune.schema.spec import parse_spec

from feedtune_cli import run_cli

REPO = Path(__file__).resolve().parents[2]
EXAMPLE_NAME = "koren-1979-sampled-data"
EXAMPLE = REPO / "examples" / f"{EXAMPLE_NAME}.json"


def run(*args: str, stdin: bytes | None = None, cwd: Path | None = None) -> subprocess.CompletedProcess:
    """``feedtune ARGS`` through the real entry point in this process (bytes in, bytes out;
    tests/feedtune_cli.py), never raising on exit status."""
    return run_cli(*args, stdin=stdin or b"", cwd=cwd or REPO)


def run_process(*args: str, exe: list[str] | None = None) -> subprocess.CompletedProcess:
    """``python -m feedtune ARGS`` (or ``exe ARGS``) in a process of its own: for the console
    script, and for what a process prints once (IPOPT's banner)."""
    command = (exe or [sys.executable, "-m", "feedtune"]) + list(args)
    return subprocess.run(command, input=b"", capture_output=True, cwd=REPO, timeout=120,
                          env={**os.environ, "PYTHONDONTWRITEBYTECODE": "1"})


def run_each(invocations: dict[str, dict]) -> dict[str, subprocess.CompletedProcess]:
    """``run(*args, **rest)`` for each named invocation."""
    return {name: run(*kw["args"], **{k: v for k, v in kw.items() if k != "args"})
            for name, kw in invocations.items()}


def stderr(proc) -> str:
    return proc.stderr.decode("utf-8", "replace")


def example() -> dict:
    return json.loads(EXAMPLE.read_bytes())


def without_times(node):
    """A result without its wall-clock fields (every key ending in ``_time``: solve,
    build, ... times); the rest of a result is deterministic."""
    if isinstance(node, dict):
        return {k: without_times(v) for k, v in node.items() if not k.endswith("_time")}
    if isinstance(node, list):
        return [without_times(v) for v in node]
    return node


def koren_exact_gain(time_constant: float, period: float, radius: float, feed: float) -> float:
    """Gain K at which the sampled loop of Koren's Fig 4 tracks the circle with zero
    radial error, |H(e^{jωT})| = 1, found with numpy/scipy only (no feedtune code).

    ZOH equivalent of K/(s(1 + sτ)), x = e^{−T/τ}:
    G(z) = K[(T − τ(1 − x))z + (τ(1 − x) − Tx)] / ((z − 1)(z − x)); H = G/(1 + G).
    """
    tau, t = time_constant, period
    x = math.exp(-t / tau)
    z = np.exp(1j * feed / radius * t)

    def excess(gain):
        g = gain * ((t - tau * (1 - x)) * z + (tau * (1 - x) - t * x)) / ((z - 1) * (z - x))
        return abs(g / (1 + g)) - 1

    return brentq(excess, 1.0, 40.0, xtol=1e-12)


# -- tune --------------------------------------------------------------------------------

def _spec_bytes(edit) -> bytes:
    spec = example()
    edit(spec)
    return json.dumps(spec).encode()


def _set(*path_and_value):
    """An edit setting spec[path...][key] = value."""
    *path, key, value = path_and_value

    def edit(spec):
        node = spec
        for part in path:
            node = node[part]
        node[key] = value

    return edit


def _infeasible(spec):
    spec["constraints"] = [{"metric": "damping_ratio", "min": 0.99}]
    spec["tunables"]["position_gain"] = {"min": 100, "max": 200}
    spec["solver"]["multistart"] = 2


@pytest.fixture(scope="module")
def tunes(tmp_path_factory):
    """Every ``feedtune tune`` of a solvable or infeasible spec."""
    out = tmp_path_factory.mktemp("tune")
    infeasible = out / "infeasible.json"
    infeasible.write_bytes(_spec_bytes(_infeasible))
    (out / "file").mkdir()
    (out / "infeasible-out").mkdir()
    runs = run_each({
        "stdout": {"args": ["tune", str(EXAMPLE)]},
        "stdin_to_file": {"args": ["tune", "-", "-o", str(out / "file" / "result.json")],
                          "stdin": EXAMPLE.read_bytes()},
        "infeasible": {"args": ["tune", str(infeasible), "-o",
                                str(out / "infeasible-out" / "result.json")]},
    })
    return runs, out


def test_tune_stdout_is_only_the_result_json(tunes):
    proc = tunes[0]["stdout"]
    assert proc.returncode == 0, stderr(proc)
    result = json.loads(proc.stdout)  # the whole of stdout, nothing else on it
    assert result["success"] is True
    assert result["status"] in ("optimal", "acceptable")
    assert result["name"] == EXAMPLE_NAME
    assert proc.stdout.startswith(b"{") and proc.stdout.endswith(b"}\n")


def test_tune_finds_the_exact_zero_radial_error_gain(tunes):
    result = json.loads(tunes[0]["stdout"].stdout)
    gain = result["tuned"]["position_gain"]
    assert gain["unit"] == "1/s"
    assert gain["fixed"] is False and gain["at_bound"] is None
    # 18.17 is the root of |H(e^{jωT})| = 1 on the 8 mm circle at 40 mm/s, T = 1/64 s;
    # Koren's eq 40 (17.98) is only its ωT → 0 limit. 1e-3 relative is far above IPOPT's
    # tolerance (1e-9) and far below the 1 % between the exact root and eq 40.
    assert gain["value"] == pytest.approx(18.17, rel=1e-3)
    assert gain["value"] == pytest.approx(koren_exact_gain(0.02, 0.015625, 0.008, 0.04), rel=1e-6)
    assert result["tuned"]["sampling_period"]["fixed"] is True


def test_tune_summary_on_stderr(tunes):
    text = stderr(tunes[0]["stdout"])
    assert EXAMPLE_NAME in text and "optimal" in text
    assert "position_gain" in text and "[1/s]" in text
    assert "(fixed)" in text  # sampling_period
    assert "damping_ratio" in text and "OK" in text
    assert "radial_error" in text and "[m]" in text
    assert "stable" in text and "spectral radius" in text
    # the example's one gain and one |e| go to the root search, which counts evaluations of
    # e (feedtune/tuner/roots.py), where IPOPT counted iterations
    assert "root search" in text and "evaluations of e" in text
    assert "build" in text and "solve" in text
    assert "Traceback" not in text


def test_tune_prints_no_warning(tunes):
    """Nothing but the summary on stderr: CasADi 3.8 warned (FutureWarning, 20 lines) when
    the pole measures handed numpy a CasADi matrix of numbers, in every ``feedtune tune``
    and ``feedtune batch`` of a spec reporting pole damping or decay rate."""
    for label, proc in tunes[0].items():
        assert "Warning" not in stderr(proc), (label, stderr(proc))


def test_tune_reads_stdin_and_writes_the_same_result_to_a_file(tunes):
    runs, out = tunes
    proc = runs["stdin_to_file"]
    assert proc.returncode == 0, stderr(proc)
    assert proc.stdout == b""
    assert "wrote" in stderr(proc) and "position_gain" in stderr(proc)
    written = json.loads((out / "file" / "result.json").read_bytes())
    assert without_times(written) == without_times(json.loads(runs["stdout"].stdout))
    assert [p.name for p in (out / "file").iterdir()] == ["result.json"]  # no temp file left


def test_solver_output_cannot_reach_stdout(capfd):
    """Whatever a solver prints to the C-level stdout while solving lands on stderr (a spec
    can no longer raise IPOPT's print_level, so C's printf stands in for IPOPT)."""
    import ctypes

    from feedtune.cli.common import stdout_to_stderr

    libc = ctypes.CDLL(None)
    with stdout_to_stderr():
        libc.printf(b"Ipopt would print this\n")
        print("and Python this")
    out, err = capfd.readouterr()
    assert out == ""
    assert "Ipopt would print this" in err and "and Python this" in err


def test_infeasible_spec_exits_1_and_still_writes_the_result(tunes):
    runs, out = tunes
    proc = runs["infeasible"]
    assert proc.returncode == 1, stderr(proc)
    assert proc.stdout == b""
    result = json.loads((out / "infeasible-out" / "result.json").read_bytes())
    assert result["success"] is False
    assert result["constraints"][0]["satisfied"] is False
    assert "VIOLATED" in stderr(proc)
    assert "Traceback" not in stderr(proc)


# -- bad specs ---------------------------------------------------------------------------

_TEXT = EXAMPLE.read_text()

#: id → (spec bytes, pointer the error must name ("" = whole document), text in message)
BAD_SPECS = {
    "negative_time_constant": (_spec_bytes(_set("plant", "time_constant", -0.02)),
                               "/plant/time_constant", "greater than 0"),
    "unknown_key": (_spec_bytes(_set("plant", "gear_ratio", 3)), "/plant/gear_ratio", "Extra inputs"),
    "unknown_tunable": (_spec_bytes(_set("tunables", "velocity_gain", {"value": 2})),
                        "/tunables/velocity_gain", "unknown tunable"),
    "empty_bounds": (_spec_bytes(_set("tunables", "position_gain", {"min": 5000})),
                     "/tunables/position_gain", "are empty"),  # found by tune(), not parse
    "nan_literal": (_TEXT.replace('"time_constant": 0.02', '"time_constant": NaN').encode(), "", "NaN"),
    "duplicate_key": (_TEXT.replace('"blu": 5e-6', '"blu": 5e-6, "blu": 1e-6').encode(), "",
                      "duplicate key 'blu'"),
    "empty_file": (b"", "", "empty"),
    "truncated_json": (EXAMPLE.read_bytes()[:120], "", "invalid JSON"),
    "not_utf8": (b'{"name": "caf\xe9"}', "", "UTF-8"),
}
assert b'"time_constant": NaN' in BAD_SPECS["nan_literal"][0]
assert b'"blu": 1e-6' in BAD_SPECS["duplicate_key"][0]
#: validate shares tune's reader and parser: one case per stage is enough for it
#: (it reads them from stdin, so its errors are labelled <stdin>)
VALIDATE_CASES = ["negative_time_constant", "unknown_tunable", "empty_bounds"]


@pytest.fixture(scope="module")
def bad_runs(tmp_path_factory):
    """``tune`` on every bad spec and ``validate`` on some, plus unreadable paths."""
    directory = tmp_path_factory.mktemp("bad")
    invocations = {}
    for case, (data, _, _) in BAD_SPECS.items():
        path = directory / f"{case}.json"
        path.write_bytes(data)
        invocations[("tune", case)] = {"args": ["tune", str(path)]}
        if case in VALIDATE_CASES:
            invocations[("validate", case)] = {"args": ["validate", "-"], "stdin": data}
    invocations[("tune", "missing")] = {"args": ["tune", str(directory / "absent.json")]}
    invocations[("validate", "missing")] = {"args": ["validate", str(directory / "absent.json")]}
    invocations[("tune", "directory")] = {"args": ["tune", str(directory)]}
    return run_each(invocations), directory


@pytest.mark.parametrize("command, case", [("tune", c) for c in BAD_SPECS]
                         + [("validate", c) for c in VALIDATE_CASES])
def test_bad_spec_exits_2_naming_the_field(command, case, bad_runs):
    runs, directory = bad_runs
    proc = runs[(command, case)]
    _, pointer, fragment = BAD_SPECS[case]
    label = "<stdin>" if command == "validate" else directory / f"{case}.json"
    text = stderr(proc)
    assert proc.returncode == 2, text
    assert proc.stdout == b""
    assert "Traceback" not in text
    lines = text.splitlines()
    prefix = f"error: {label}: {pointer}: " if pointer else f"error: {label}: "
    assert any(line.startswith(prefix) and fragment in line for line in lines), text
    assert all(line.startswith("error: ") for line in lines), text


def test_bad_spec_error_line_is_exact(bad_runs):
    runs, directory = bad_runs
    path = directory / "negative_time_constant.json"
    assert stderr(runs[("tune", "negative_time_constant")]) == (
        f"error: {path}: /plant/time_constant: Input should be greater than 0\n")


@pytest.mark.parametrize("command, case, message", [("tune", "missing", "no such file"),
                                                    ("validate", "missing", "no such file"),
                                                    ("tune", "directory", "is a directory")])
def test_unreadable_spec_exits_2(command, case, message, bad_runs):
    proc = bad_runs[0][(command, case)]
    assert proc.returncode == 2
    assert proc.stdout == b""
    assert message in stderr(proc) and "Traceback" not in stderr(proc)


# -- validate, schema, plants, metrics, examples, version ---------------------------------

def test_validate_ok():
    proc = run("validate", str(EXAMPLE))
    assert proc.returncode == 0
    assert proc.stdout == b""
    assert stderr(proc) == f"ok: {EXAMPLE_NAME}\n"


def test_schema_is_a_json_object_with_units():
    proc = run("schema")
    assert proc.returncode == 0
    schema = json.loads(proc.stdout)
    assert isinstance(schema, dict) and "properties" in schema
    assert {"plant", "tunables", "objective"} <= set(schema["properties"])
    assert "[s]" in proc.stdout.decode()  # time constant and sampling-period units


def test_plants_text_lists_every_plant_with_units():
    proc = run("plants")
    assert proc.returncode == 0
    text = proc.stdout.decode()
    assert "software_servo" in text
    for name in PLANTS:
        assert name in text
    assert "time_constant" in text and "[s]" in text
    assert "position_gain" in text and "[1/s]" in text
    assert "required" in text and "default 8" in text  # counter_bits
    for key, plant_cls in PLANTS.items():  # every structure's tunables, compensators' too
        for tunables in _tunables_by_structure(key, plant_cls).values():
            for name in tunables:
                assert f"    {name} " in text, (key, name)


def test_plants_json_matches_the_registry():
    proc = run("plants", "--json")
    assert proc.returncode == 0
    plants = json.loads(proc.stdout)
    assert set(plants) == set(PLANTS) | set(DATA_PLANTS)  # DATA_PLANTS: the convex technique's
    servo = plants["software_servo"]
    params = {p["name"]: p for p in servo["parameters"]}
    assert params["time_constant"]["unit"] == "s" and params["time_constant"]["required"]
    assert params["counter_bits"]["default"] == 8
    assert set(servo["tunables"]) == {"reference_pulse", "sampled_data"}
    assert set(servo["tunables"]["reference_pulse"]) == {"position_gain"}
    period = servo["tunables"]["sampled_data"]["sampling_period"]
    assert period["unit"] == "s" and 0 < period["min"] < period["max"]
    for key, plant_cls in PLANTS.items():
        listed = plants[key]["tunables"]
        for technique, tunables in _tunables_by_structure(key, plant_cls).items():
            assert set(tunables) <= set(listed[technique]), (key, technique)
            for name, tunable in tunables.items():
                entry = listed[technique][name]
                assert (entry["unit"], entry["min"], entry["max"]) == (tunable.unit, tunable.min,
                                                                       tunable.max)


def _tunables_by_structure(key: str, plant_cls) -> dict[str, dict]:
    """Every tunable a plant has for some value of one of its Literal fields (technique,
    compensator kinds), per technique ("*" without one): what ``feedtune plants`` must list."""
    fields = plant_cls.Params.model_fields
    literals = {name: typing.get_args(info.annotation) for name, info in fields.items()
                if name != "type" and typing.get_origin(info.annotation) is typing.Literal}
    techniques = literals.pop("technique", (None,))
    out: dict[str, dict] = {}
    for technique in techniques:
        base = {"type": key} | ({"technique": technique} if technique else {})
        found = out.setdefault(technique or "*", {})
        for field, values in [(None, (None,))] + list(literals.items()):
            for value in values:
                extra = {field: value} if field else {}
                found.update(plant_cls(plant_cls.Params.model_construct(**base, **extra)).tunables())
    return out


def test_metrics_text_lists_every_metric_with_units():
    proc = run("metrics")
    assert proc.returncode == 0
    text = proc.stdout.decode()
    for name, metric in METRICS.items():
        assert name in text
        assert f"[{metric.unit}]" in text
    assert "radial_error [m]" in text
    assert "radius" in text and "Circle radius r [m]" in text


def test_metrics_json_matches_the_registry():
    proc = run("metrics", "--json")
    assert proc.returncode == 0
    metrics = json.loads(proc.stdout)
    # DATA_METRICS: the convex technique's own (measured data), as DATA_PLANTS for plants
    assert set(metrics) == set(METRICS) | set(DATA_METRICS)
    radial = metrics["radial_error"]
    assert radial["unit"] == "m" and radial["reference"]
    assert {o["name"] for o in radial["options"]} == {"radius", "feed"}


def test_examples_lists_the_bundled_specs():
    proc = run("examples")
    assert proc.returncode == 0
    listed = [line.split()[0] for line in proc.stdout.decode().splitlines()]
    assert EXAMPLE_NAME in listed
    assert listed == sorted(p.stem for p in (REPO / "examples").glob("*.json"))
    assert "Koren 1979" in proc.stdout.decode()
    # the first sentence, not cut at an abbreviation ("Bhatia 1971 (Ch. IV): …")
    assert "Bhatia 1971 (Ch. IV): rotary" in proc.stdout.decode()
    for line in proc.stdout.decode().splitlines():
        assert len(line) <= 100
    for stem in listed:  # each one a spec the CLI accepts (parsed here: no extra process)
        assert parse_spec((REPO / "examples" / f"{stem}.json").read_bytes()).name


def test_examples_copies_a_spec_that_parses(tmp_path):
    proc = run("examples", EXAMPLE_NAME, "-o", "x.json", cwd=tmp_path)
    assert proc.returncode == 0, stderr(proc)
    copied = (tmp_path / "x.json").read_bytes()
    assert copied == EXAMPLE.read_bytes()
    assert parse_spec(copied).name == EXAMPLE_NAME


def test_examples_prints_a_spec_to_stdout():
    proc = run("examples", EXAMPLE_NAME)
    assert proc.returncode == 0
    assert proc.stdout == EXAMPLE.read_bytes()


def test_unknown_example_exits_2_listing_known_ones():
    proc = run("examples", "no-such-example")
    assert proc.returncode == 2
    assert proc.stdout == b""
    assert EXAMPLE_NAME in stderr(proc) and "no-such-example" in stderr(proc)


def test_version():
    proc = run("--version")
    assert proc.returncode == 0
    assert feedtune.__version__ in proc.stdout.decode()


def test_console_script():
    script = Path(sys.executable).parent / ("feedtune.exe" if os.name == "nt" else "feedtune")
    if not script.exists():
        pytest.skip(f"no console script at {script}")
    proc = run_process("examples", exe=[str(script)])
    assert proc.returncode == 0, stderr(proc)
    assert EXAMPLE_NAME in proc.stdout.decode()


def test_help_gives_units_and_exit_statuses():
    proc = run("tune", "--help")
    assert proc.returncode == 0
    text = proc.stdout.decode()
    assert "Exit status" in text and "stdout" in text


def test_a_spec_without_free_tunables_prints_no_ipopt_banner():
    """Nothing is optimised, so IPOPT's only run is the version probe of the provenance
    block: its banner must not reach the terminal (it did, on stderr)."""
    proc = run_process("tune", str(REPO / "examples" / "sato-table2-a.json"))
    assert proc.returncode == 0, stderr(proc)
    assert "Ipopt" not in stderr(proc) and b"Ipopt" not in proc.stdout
