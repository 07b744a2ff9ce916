"""A spec of measured frequency responses from the command line: the bundled example
(examples/datadriven/hydraulic-three-loads.json) tunes by the convex technique through
the real entry point (tests/feedtune_cli.py), bad data is exit 2 naming its field, and
nothing is written on failure; the plant block from measured files (frd_plant_block) is a spec feedtune takes."""

from __future__ import annotations

import base64
import copy
import json
import subprocess
from pathlib import Path

import numpy as np
import pytest

from feedtune.measured.data import read_data, to_csv, FrequencyResponseData
from feedtune.measured.datadriven_spec import frd_plant_block
from feedtune.schema.spec import SpecError, parse_spec
from feedtune_cli import run_cli

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "examples" / "datadriven" / "hydraulic-three-loads.json"


def run(*args: str, stdin: bytes = b"") -> subprocess.CompletedProcess:
    """``feedtune ARGS`` through the real entry point in this process (bytes out;
    tests/feedtune_cli.py): nothing here tests the process itself."""
    return run_cli(*args, stdin=stdin, cwd=REPO)


@pytest.fixture(scope="module")
def example() -> dict:
    return json.loads(EXAMPLE.read_text())


@pytest.fixture(scope="module")
def tuned_with_report(tmp_path_factory) -> tuple[Path, subprocess.CompletedProcess]:
    """``feedtune tune EXAMPLE -o DIR/result.json --report DIR/report``, run once: (DIR,
    the command's status and output). The tuned result and its report are read by the
    tests below; the example was tuned twice (≈ 2.3 s of CPU each), once for each."""
    root = tmp_path_factory.mktemp("datadriven")
    proc = run("tune", str(EXAMPLE), "-o", str(root / "result.json"), "--report",
               str(root / "report"))
    return root, proc


@pytest.fixture(scope="module")
def tuned(tuned_with_report) -> dict:
    root, proc = tuned_with_report
    assert proc.returncode == 0, proc.stderr.decode()
    assert proc.stdout == b""  # -o: the JSON goes to the file, nothing to stdout
    return json.loads((root / "result.json").read_text())


def test_example_tunes_by_the_convex_technique(tuned):
    """Optimal, every bound met on every set, stability certified by Nyquist on the band."""
    assert tuned["success"] and tuned["status"] == "optimal"
    assert tuned["solver"]["method"] == "convex"
    assert all(c["satisfied"] for c in tuned["constraints"])
    for name in ("half-load", "design-load", "double-load"):
        assert tuned["metrics"][f"m_peak(set={name})"]["value"] <= 1.3 * (1 + 1e-6)
        assert tuned["metrics"][f"sensitivity_peak(set={name})"]["value"] <= 2.0 * (1 + 1e-6)
    stability = tuned["stability"]
    assert stability["stable"] and stability["certified_by"] == "nyquist"
    assert stability["band"] == [0.1, 10000.0]
    assert [s["name"] for s in stability["sets"]] == ["half-load", "design-load", "double-load"]
    assert all(s["stable"] for s in stability["sets"])
    assert tuned["objective"] == pytest.approx(-tuned["metrics"]["bandwidth"]["value"])
    assert set(tuned["tuned"]) == {"controller.kp", "controller.ki", "controller.kd"}
    assert tuned["tuned"]["controller.kp"]["unit"] == "V/rad"


def test_stdout_is_the_result_json_only(example):
    """Without -o the JSON is all of stdout (the summary on stderr). One set, every fifth
    of its frequencies (100): what is tested is where the result goes, and the convex
    design's work grows with the points (≈ 1.3 → 0.5 s of CPU)."""
    spec = copy.deepcopy(example)
    spec["plant"]["sets"] = spec["plant"]["sets"][1:2]
    for key in ("frequency", "real", "imag"):
        spec["plant"]["sets"][0][key] = spec["plant"]["sets"][0][key][::5]
    proc = run("tune", "-", stdin=json.dumps(spec).encode())
    assert proc.returncode == 0, proc.stderr.decode()
    assert json.loads(proc.stdout)["solver"]["method"] == "convex"


def test_validate_accepts_the_example():
    proc = run("validate", str(EXAMPLE))
    assert proc.returncode == 0, proc.stderr.decode()
    assert b"ok: hydraulic-three-loads" in proc.stderr


def _broken(example, edit) -> dict:
    spec = copy.deepcopy(example)
    edit(spec)
    return spec


def _set(spec, key, value, index=0):
    spec["plant"]["sets"][index][key] = value


BAD = {
    "non-monotone frequency": (lambda s: s["plant"]["sets"][0]["frequency"].__setitem__(3, 0.01),
                               "/plant/sets/0/frequency"),
    "missing frequency unit": (lambda s: s["plant"]["sets"][1].pop("frequency_unit"),
                               "/plant/sets/1/frequency_unit"),
    "unknown frequency unit": (lambda s: _set(s, "frequency_unit", "kHz", 2),
                               "/plant/sets/2/frequency_unit"),
    "imag shorter": (lambda s: _set(s, "imag", s["plant"]["sets"][0]["imag"][:-1]),
                     "/plant/sets/0"),
    "too few points": (lambda s: [_set(s, k, s["plant"]["sets"][0][k][:3])
                                  for k in ("frequency", "real", "imag")],
                       "/plant/sets/0/frequency"),
    "missing real": (lambda s: s["plant"]["sets"][0].pop("real"), "/plant/sets/0/real"),
    "string in data": (lambda s: _set(s, "real", ["1.0"] * 500), "/plant/sets/0/real/0"),
    "negative frequency": (lambda s: s["plant"]["sets"][0]["frequency"].__setitem__(0, -1.0),
                           "/plant/sets/0/frequency/0"),
    "pid without filter": (lambda s: s["plant"].pop("filter_time_constant"), "/plant"),
    "unknown tunable": (lambda s: s["tunables"].__setitem__("controller.kf", {"value": 1}),
                        "/tunables/controller.kf"),
    "a file named": (lambda s: s["plant"].__setitem__("file", "/etc/passwd"), "/plant/file"),
    "two objectives": (lambda s: s["objective"].append({"metric": "crossover_frequency"}),
                       "/objective"),
    "a lower bound": (lambda s: s["constraints"][0].__setitem__("min", 1.0),
                      "/constraints/0/min"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_data_names_the_field(example, case):
    edit, pointer = BAD[case]
    with pytest.raises(SpecError) as caught:
        parse_spec(_broken(example, edit))
    assert pointer in [p for p, _ in caught.value.errors], caught.value.errors


def test_nan_in_the_data_is_exit_2_with_its_pointer_and_nothing_written(example, tmp_path):
    text = json.dumps(example).replace('"real": [', '"real": [NaN, ', 1)
    spec = json.loads(json.dumps(example))
    spec_path = tmp_path / "nan.json"
    spec_path.write_text(text)
    out = tmp_path / "result.json"
    proc = run("tune", str(spec_path), "-o", str(out))
    assert proc.returncode == 2
    assert b"/plant/sets/0/real/0" in proc.stderr, proc.stderr.decode()
    assert not out.exists()
    assert spec["plant"]["sets"][0]["real"][0] == example["plant"]["sets"][0]["real"][0]


def test_plant_block_from_measured_files_is_a_spec_feedtune_takes(example, tmp_path):
    """Two measured files (feedtune/measured/data.py's CSV, frequency in Hz) become the
    plant block; a spec with it parses, its frequencies in rad/s within an ulp."""
    paths = []
    for item in example["plant"]["sets"][:2]:
        omega = np.array(item["frequency"])
        data = FrequencyResponseData(omega, np.array(item["real"]) + 1j * np.array(item["imag"]),
                                     None, input_unit="V", output_unit="rad",
                                     source=item["name"])
        path = tmp_path / f"{item['name']}.csv"
        path.write_bytes(to_csv(data))
        paths.append(path)
    block = frd_plant_block([read_data(p) for p in paths], controller="pid",
                            filter_time_constant=0.002)
    assert [s["name"] for s in block["sets"]] == ["half-load", "design-load"]
    np.testing.assert_allclose(block["sets"][0]["frequency"],
                               example["plant"]["sets"][0]["frequency"], rtol=4e-16)
    spec = parse_spec({**example, "plant": block})
    assert spec.plant.input_unit == "V" and spec.plant.output_unit == "rad"


def test_a_velocity_response_is_integrated():
    """rad/s/V becomes rad/V: G_position = G_velocity/(jω), exactly."""
    omega = np.logspace(0, 3, 20)
    velocity = 1 / (1j * omega * 0.01 + 1)
    data = FrequencyResponseData(omega, velocity, None, input_unit="V", output_unit="rad/s",
                                 source="v.csv")
    block = frd_plant_block([data])
    assert block["output_unit"] == "rad" and block["sets"][0]["name"] == "v"
    got = np.array(block["sets"][0]["real"]) + 1j * np.array(block["sets"][0]["imag"])
    np.testing.assert_allclose(got, velocity / (1j * omega), rtol=1e-15)


def test_identify_model_frd_writes_a_block_that_tunes(tmp_path):
    """``feedtune identify FILES --model frd -o PLANT.json`` through the entry point: the
    bundled hydraulic velocity responses become a block; a spec with it (PI, M_peak ≤ 1.3)
    tunes by the convex technique. A time series is exit 2, nothing written."""
    files = [str(REPO / "examples" / "data" / f"hydraulic-frf-{i}.csv") for i in (1, 2)]
    plant = tmp_path / "plant.json"
    proc = run("identify", *files, "--model", "frd", "-o", str(plant))
    assert proc.returncode == 0, proc.stderr.decode()
    block = json.loads(plant.read_text())
    assert json.loads(proc.stdout) == block
    assert [s["name"] for s in block["sets"]] == ["hydraulic-frf-1", "hydraulic-frf-2"]
    spec = {"name": "from-identify", "plant": block,
            "tunables": {"controller.kp": {"min": 0.01, "max": 100, "initial": 0.1},
                         "controller.ki": {"min": 1e-3, "max": 100, "initial": 1e-3}},
            "objective": [{"metric": "bandwidth", "goal": "maximize"}],
            "constraints": [{"metric": "m_peak", "max": 1.3}]}
    proc = run("tune", "-", stdin=json.dumps(spec).encode())
    assert proc.returncode == 0, proc.stderr.decode()
    result = json.loads(proc.stdout)
    assert result["stability"]["stable"] and result["constraints"][0]["satisfied"]
    bad = tmp_path / "bad.json"
    proc = run("identify", str(REPO / "examples" / "data" / "software-servo-step.csv"),
               "--model", "frd", "-o", str(bad))
    assert proc.returncode == 2 and b"not a time series" in proc.stderr
    assert not bad.exists()


def test_plants_and_metrics_document_the_technique():
    """``feedtune plants`` lists the data plant with its tunables' units; ``feedtune
    metrics`` says which metrics the convex technique widens, bounds or reports."""
    plants = json.loads(run("plants", "--json").stdout)
    frd = plants["frequency_response_data"]
    assert frd["tunables"]["*"]["controller.kd"]["unit"] == "V·s/m"
    assert {p["name"] for p in frd["parameters"]} >= {"sets", "integrators", "unstable_poles",
                                                      "controller", "filter_time_constant"}
    table = json.loads(run("metrics", "--json").stdout)
    label = "frequency_response_data(technique=convex)"
    held = {name for name, m in table.items() if label in m["supported"]}
    assert held == {"bandwidth", "crossover_frequency", "m_peak", "sensitivity_peak",
                    "phase_margin", "weighted_sensitivity"}
    weighted = table["weighted_sensitivity"]  # only the data have it: W's options, units
    assert weighted["unit"] == "1" and weighted["supported"] == [label]
    assert weighted["options_at"] == "sensitivity_weight"
    assert {o["name"]: o["unit"] for o in weighted["options"]} == {
        "bandwidth": "rad/s", "peak": "1", "low_gain": "1"}
    text = run("metrics").stdout.decode()
    assert "weighted_sensitivity [1]:" in text and "options (sensitivity_weight):" in text
    assert label in table["phase_margin"]["reported_only"]
    assert label not in table["m_peak"]["reported_only"]


# -- the JSON schema and the weighted sensitivity through the CLI ---------------------------

def test_schema_holds_the_data_driven_spec_with_units():
    """``feedtune schema`` is one schema for both kinds of spec: exactly one of the
    model-based spec and the data-driven one, whose plant block lists the measured sets'
    fields with their units; the top level still lists every field."""
    proc = run_cli("schema")
    assert proc.returncode == 0
    schema = json.loads(proc.stdout)
    assert schema["oneOf"] == [{"$ref": "#/$defs/ModelSpec"}, {"$ref": "#/$defs/DataDrivenSpec"}]
    defs = schema["$defs"]
    assert defs["DataDrivenSpec"]["properties"]["plant"] == {
        "$ref": "#/$defs/FrequencyResponseDataParams"}
    plant = defs["FrequencyResponseDataParams"]["properties"]
    assert plant["type"]["const"] == "frequency_response_data"
    assert "[count]" in plant["integrators"]["description"]
    assert "[count]" in plant["unstable_poles"]["description"]
    assert "[s]" in plant["filter_time_constant"]["description"]
    assert plant["sets"]["items"] == {"$ref": "#/$defs/FrequencySetSpec"}
    data_set = defs["FrequencySetSpec"]["properties"]
    assert data_set["frequency_unit"]["enum"] == ["rad/s", "Hz"]
    assert "[frequency_unit]" in data_set["frequency"]["description"]
    for part in ("real", "imag"):
        assert "[position unit per command unit" in data_set[part]["description"]
    weight = defs["SensitivityWeightSpec"]["properties"]
    assert "[rad/s]" in weight["bandwidth"]["description"]
    assert "[1]" in weight["peak"]["description"] and "[1]" in weight["low_gain"]["description"]
    # the model-based spec's plants do not take measured data: the two forms exclude each other
    model_plants = json.dumps(defs["ModelSpec"]["properties"]["plant"])
    assert "FrequencyResponseDataParams" not in model_plants
    assert {"plant", "objective", "sensitivity_weight", "robust"} <= set(schema["properties"])


def test_weighted_sensitivity_tunes_and_needs_its_weight(example, tmp_path):
    """Minimising max |W S| over the three loads from the command line: the result reports
    the metric per set with unit 1 and a positive objective (minimised); without the weight
    the spec is exit 2 at /sensitivity_weight and nothing is written."""
    spec = {**copy.deepcopy(example),
            "objective": [{"metric": "weighted_sensitivity", "goal": "minimize"}]}
    bad = tmp_path / "no-weight.json"
    bad.write_text(json.dumps(spec))
    out = tmp_path / "result.json"
    proc = run_cli("tune", str(bad), "-o", str(out))
    assert proc.returncode == 2 and b"/sensitivity_weight:" in proc.stderr
    assert not out.exists()
    spec["sensitivity_weight"] = {"bandwidth": 20.0, "peak": 2.0, "low_gain": 1e-3}
    good = tmp_path / "weighted.json"
    good.write_text(json.dumps(spec))
    proc = run_cli("tune", str(good), "-o", str(out))
    assert proc.returncode == 0, proc.stderr.decode()
    result = json.loads(out.read_text())
    value = result["metrics"]["weighted_sensitivity"]["value"]
    assert result["metrics"]["weighted_sensitivity"]["unit"] == "1"
    assert result["objective"] == pytest.approx(value, rel=1e-12) and 0.9 < value < 1.2
    per_set = [result["metrics"][f"weighted_sensitivity(set={s['name']})"]["value"]
               for s in example["plant"]["sets"]]
    assert max(per_set) == pytest.approx(value, rel=1e-12)
    spec["objective"][0]["goal"] = "maximize"
    good.write_text(json.dumps(spec))
    proc = run_cli("validate", str(good))
    assert proc.returncode == 2 and b"/objective/0" in proc.stderr


# -- the report of a data-driven result ---------------------------------------------------

#: matplotlib's first three cycle colours (C0, C1, C2): one per data set of the example
SET_COLOURS = [(31, 119, 180), (255, 127, 14), (44, 160, 44)]


def test_tune_report_draws_every_measured_set(example, tuned_with_report):
    """``feedtune tune SPEC --report DIR`` on the three-load example: the Nyquist plot, the
    Bode plot of L and |S|, |T| against their bounds are written, each with a curve of
    every set's colour, embedded in report.html and listed in the report's manifest; the
    page's validation section says the independent check agreed."""
    from matplotlib.image import imread

    root, proc = tuned_with_report
    out = root / "report"
    assert proc.returncode == 0, proc.stderr.decode()
    page = (out / "report.html").read_text(encoding="utf-8")
    manifest = json.loads((out / ".feedtune-report.json").read_text())
    assert "Not drawn" not in page
    for stem, title in (("measured_nyquist", "Measured open loop (Nyquist)"),
                        ("measured_bode", "Measured open loop (Bode)"),
                        ("measured_sensitivity", "Sensitivity and complementary sensitivity")):
        png = (out / f"{stem}.png").read_bytes()
        assert png.startswith(b"\x89PNG") and f"{stem}.png" in manifest["files"]
        assert f"<h2>{title}</h2>" in page
        assert base64.b64encode(png).decode("ascii") in page
        pixels = np.rint(imread(str(out / f"{stem}.png"))[..., :3] * 255).astype(int)
        for colour in SET_COLOURS:  # every set is drawn (markers and lines in its colour)
            hits = np.all(pixels == colour, axis=-1).sum()
            assert hits > 50, (stem, colour, hits)
    assert "every gap within its tolerance" in page
    for name in (s["name"] for s in example["plant"]["sets"]):
        assert f"stable(set={name})" in page and f"m_peak(set={name},bound=max)" in page
