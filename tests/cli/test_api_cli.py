"""``feedtune tune`` and ``feedtune.tune`` are one code path: the same JSON bytes apart from
the wall-clock fields, the same summary, the same report; and the Python example script
(examples/tune_from_python.py) runs."""

from __future__ import annotations

import contextlib
import io
import json
import os
import re
import runpy
import subprocess
import sys
from pathlib import Path

import matplotlib.image
import pytest

import feedtune
from feedtune_cli import _exit_status, run_cli

REPO = Path(__file__).resolve().parents[2]
EXAMPLES = sorted((REPO / "examples").glob("*.json"))
#: the wall-clock fields of a result [s]: solver.solve_time, solver.build_time,
#: solver.evaluation_time and each solver.starts[i].solve_time; everything else is
#: deterministic
TIME_FIELDS = ("solve_time", "build_time", "evaluation_time")
_TIMES = re.compile(r'"(' + "|".join(TIME_FIELDS) + r')": [0-9.e+-]+')


def without_times(text: str) -> str:
    """The result JSON with every time field's number replaced by 0, all else byte for byte."""
    return _TIMES.sub(lambda m: f'"{m.group(1)}": 0', text)


def feedtune_cli(*args: str) -> subprocess.CompletedProcess:
    """``feedtune ARGS`` through the real entry point in this process (text out;
    tests/feedtune_cli.py)."""
    return run_cli(*args, cwd=REPO, text=True)


#: tuned from scratch on both paths: one example per plant type and technique (sampled
#: software servo, Padé model, pulse generator, Bhatia's cascade), so the solver's starts,
#: statuses and optimum notes are compared too
SOLVED = ("koren-1979-sampled-data", "sato-table2-b", "tian-vf-pulse", "bhatia-1971-hydraulic")


def spec_file(path: Path, directory: Path) -> Path:
    """The example itself if it is in SOLVED; otherwise a copy with every tunable fixed at
    its initial value, so both paths only evaluate (every metric and report of the example
    still goes through both writers, at a fraction of a tuning's time: the two paths are one
    code path, and tuning all 12 twice took about 2 min of the suite at load 9)."""
    if path.stem in SOLVED:
        return path
    spec = json.loads(path.read_text(encoding="utf-8"))
    spec["tunables"] = {name: {"value": t.get("initial", t.get("value", t.get("min")))}
                        for name, t in spec["tunables"].items()}
    fixed = directory / path.name
    fixed.write_text(json.dumps(spec), encoding="utf-8")
    return fixed


@pytest.mark.parametrize("path", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_the_api_and_the_command_line_write_the_same_bytes_apart_from_times(path, tmp_path):
    path = spec_file(path, tmp_path)
    proc = feedtune_cli("tune", str(path), "-o", str(tmp_path / "cli.json"), "-q")
    written = (tmp_path / "cli.json").read_text(encoding="utf-8")
    result = feedtune.tune(path)
    assert proc.returncode == (0 if result.success else 1), proc.stderr
    assert len(_TIMES.findall(written)) == 3 + len(result.data.solver.starts)
    assert without_times(result.to_json()) == without_times(written)


def test_the_command_lines_summary_is_the_results(tmp_path):
    path = REPO / "examples" / "koren-1979-sampled-data.json"
    proc = feedtune_cli("tune", str(path), "-o", str(tmp_path / "result.json"))
    assert proc.returncode == 0, proc.stderr
    summary = feedtune.load_result(tmp_path / "result.json").summary()
    assert summary + "\n" in proc.stderr
    assert summary.splitlines()[0].startswith("koren-1979-sampled-data: optimal")


def test_the_api_report_is_feedtune_reports(tmp_path):
    """``Result.report(dir)`` and ``feedtune report RESULT --out DIR`` write the same files,
    byte for byte (a report is deterministic)."""
    result = feedtune.tune(REPO / "examples" / "sato-table2-a.json")
    result.save(tmp_path / "result.json")
    api = result.report(tmp_path / "api")
    proc = feedtune_cli("report", str(tmp_path / "result.json"), "--out", str(tmp_path / "cli"))
    assert proc.returncode == 0, proc.stderr
    names = sorted(p.name for p in (tmp_path / "cli").iterdir())
    assert names == sorted(p.name for p in (tmp_path / "api").iterdir())
    drawn = [stem for stem in ("responses", "bode", "circle", "poles") if stem not in api.left_out]
    assert [api.page.name, *(p.name for p in api.figures)] == [
        "report.html", *(f"{stem}.png" for stem in drawn)]
    for stem, why in api.left_out.items():  # the command names what it left out, and why
        assert f"{stem} ({why})" in proc.stderr
    for name in names:
        assert (tmp_path / "api" / name).read_bytes() == (tmp_path / "cli" / name).read_bytes()


def run_example(script: Path, *args: str, cwd: Path) -> subprocess.CompletedProcess:
    """``python SCRIPT ARGS`` in this process: the script run as ``__main__`` (runpy) with
    ``sys.argv`` and the working directory as the interpreter would set them, its stdout and
    stderr captured; status 0, or its ``SystemExit``'s as ``sys.exit`` maps it. Saved against a process: the ≈ 2 s of CPU a fresh interpreter
    spends importing numpy, scipy, CasADi, python-control and matplotlib; what is tested is
    the script's work, not the interpreter's start (the example sets the Agg backend
    itself, so no display is needed here either)."""
    out, err = io.StringIO(), io.StringIO()
    status = 0
    argv, before = sys.argv, os.getcwd()
    sys.argv = [str(script), *args]
    os.chdir(cwd)
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            runpy.run_path(str(script), run_name="__main__")
    except SystemExit as exc:
        status, message = _exit_status(exc.code)
        err.write(message)
    finally:
        sys.argv = argv
        os.chdir(before)
    return subprocess.CompletedProcess(["python", str(script), *args], status, out.getvalue(),
                                       err.getvalue())


def test_the_python_example_tunes_and_plots(tmp_path):
    """examples/tune_from_python.py: a user-defined two-mass drive built in code, tuned,
    exported to python-control and plotted into the file named on its command line; the
    same tuning as examples/user-defined-drive.json through the command line."""
    figure, saved = tmp_path / "servo.png", tmp_path / "result.json"
    proc = run_example(REPO / "examples" / "tune_from_python.py", str(figure), "--result",
                       str(saved), cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "user-drive-from-python: optimal" in proc.stdout
    assert re.search(r"gain margin \d+(\.\d+)? \[1\], phase margin \d+(\.\d+)? \[deg\]",
                     proc.stdout)
    image = matplotlib.image.imread(figure)
    assert image.shape[0] > 400 and image.shape[1] > 400
    result = feedtune.load_result(saved)
    assert result.success and result.name == "user-drive-from-python"
    assert result.units["velocity_controller.kp"] == "N·m·s/rad"
    # the bundled spec of the same drive, tuned by the command line: the same numbers (one
    # code path and the same spec apart from its name; 1e-9 relative is IPOPT's tolerance)
    proc = feedtune_cli("tune", str(REPO / "examples" / "user-defined-drive.json"), "-o",
                        str(tmp_path / "cli.json"), "-q")
    assert proc.returncode == 0, proc.stderr
    cli = feedtune.load_result(tmp_path / "cli.json")
    for name, value in cli.values.items():
        assert result.values[name] == pytest.approx(value, rel=1e-9), name
    assert result.metrics["bandwidth"].value == pytest.approx(
        cli.metrics["bandwidth"].value, rel=1e-9)


def test_the_readmes_python_api_example_runs(tmp_path, monkeypatch):
    """The first Python block of README.md's "Python API" section, run as written (in an
    empty directory, where it writes result.json and report/), then the loop it exports
    closed by signal names as "Continuing in python-control" says."""
    import control
    import numpy as np

    readme = (REPO / "README.md").read_text(encoding="utf-8")
    section = readme[readme.index("## Python API"):readme.index("## Continuing in python-control")]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    monkeypatch.chdir(tmp_path)
    scope: dict = {}
    exec(compile(code, "README.md", "exec"), scope)  # noqa: S102 — our own README
    result, systems = scope["result"], scope["systems"]
    assert result.success and (tmp_path / "report" / "report.html").is_file()
    assert feedtune.load_result(tmp_path / "result.json").to_json() == result.to_json()
    closed = control.interconnect(
        [systems.open_loop, control.summing_junction(["reference", "-position"], "error")],
        inputs="reference", outputs="position")
    z = np.exp(1j * np.geomspace(0.1, 100, 20) * systems.dt)
    np.testing.assert_allclose([complex(closed(x)) for x in z],
                               [complex(systems.closed_loop(x)) for x in z], rtol=1e-9)
