"""The Python API (``feedtune.tune``, ``feedtune.Result``, ``feedtune.load_result``) in
process: the forms a spec may take, errors as exceptions naming the field, the result
object, atomic saving, BLAS threads within the call, and a light ``import feedtune``.
What the command line writes is compared with the API in tests/cli/test_api_cli.py."""

from __future__ import annotations

import copy
import gc
import json
import os
import pydoc
import re
import subprocess
import sys
from pathlib import Path

import pytest
from threadpoolctl import threadpool_info, threadpool_limits

import feedtune
import feedtune.problem
from feedtune.api import Result, ResultError
from feedtune.schema.spec import parse_spec

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "examples" / "koren-1979-sampled-data.json"
#: the wall-clock fields of a result, the only ones that differ between two tunings
TIME_FIELDS = re.compile(r'"(solve_time|build_time|evaluation_time)": [0-9.e+-]+')


def spec_dict(**solver) -> dict:
    """Koren's sampled-data example (README), fewer starts: K free, T fixed."""
    spec = json.loads(EXAMPLE.read_bytes())
    spec["solver"] = {"multistart": 2, **solver}
    return spec


def without_times(text: str) -> str:
    return TIME_FIELDS.sub(lambda m: f'"{m.group(1)}": 0', text)


@pytest.fixture(scope="module")
def result() -> Result:
    return feedtune.tune(spec_dict())


# -- import and documentation --------------------------------------------------------------

def test_import_feedtune_loads_no_heavy_package():
    """``import feedtune`` stays light (the command line's start-up, issue 15): the API is
    loaded on first use only."""
    probe = ("import json, sys, feedtune; print(json.dumps(sorted({n.split('.')[0] for n in "
             "sys.modules if n.split('.')[0] in ('casadi', 'numpy', 'scipy', 'pydantic', "
             "'control', 'matplotlib', 'click', 'threadpoolctl')} | {n for n in sys.modules "
             "if n.startswith('feedtune.')})))")
    proc = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                          timeout=60, check=True)
    assert json.loads(proc.stdout) == []


def test_the_api_loads_on_first_use():
    probe = ("import sys, feedtune; feedtune.tune; print('casadi' in sys.modules, "
             "'feedtune.api' in sys.modules)")
    proc = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                          timeout=60, check=True)
    assert proc.stdout.split() == ["True", "True"]


def test_every_public_name_resolves_and_help_lists_it():
    text = pydoc.render_doc(feedtune, renderer=pydoc.plaintext)
    for name in feedtune.__all__:
        assert getattr(feedtune, name) is not None
        assert name in dir(feedtune)
        assert re.search(rf"\b{re.escape(name)}\b", text), name
    assert {"tune", "load_result", "Result", "Spec", "SpecError"} <= set(feedtune.__all__)
    with pytest.raises(AttributeError, match="no attribute 'nonsense'"):
        feedtune.nonsense  # noqa: B018


@pytest.mark.parametrize("obj, sections", [
    ("tune", ("Parameters", "Returns", "Raises", "Examples")),
    ("load_result", ("Parameters", "Returns", "Raises", "Examples")),
    ("Result", ("Parameters", "Attributes", "Examples")),
    ("Result.save", ("Parameters", "Returns", "Raises")),
    ("Result.report", ("Parameters", "Returns", "Raises")),
    ("Result.to_control", ("Returns", "Raises", "Examples")),
    ("Result.to_json", ("Returns",)),
    ("ControlSystems", ("Attributes",)),
    ("ReportFiles", ("Attributes",)),
    ("Spec", ("Parameters", "Examples")),
    ("SpecError", ("Attributes",)),
])
def test_public_names_have_numpydoc_sections(obj, sections):
    target = feedtune
    for part in obj.split("."):
        target = getattr(target, part)
    doc = target.__doc__ or ""
    for section in sections:
        assert re.search(rf"^\s*{section}\n\s*-{{{len(section)}}}$", doc, re.M), (obj, section)


def test_the_docstring_example_of_tune_holds():
    """The Examples section of ``feedtune.tune`` is run as a doctest."""
    import doctest

    finder = doctest.DocTestFinder(exclude_empty=True)
    [test] = [t for t in finder.find(feedtune.tune, "tune", globs={"feedtune": feedtune})]
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
    runner.run(test)
    assert runner.summarize(verbose=False).failed == 0
    assert runner.summarize(verbose=False).attempted >= 2


# -- a spec in any form ------------------------------------------------------------------------

def test_dict_path_and_spec_objects_give_the_same_result(result, tmp_path):
    path = tmp_path / "spec.json"
    path.write_text(json.dumps(spec_dict()))
    expected = without_times(result.to_json())
    for spec in (str(path), path, feedtune.Spec.model_validate(spec_dict()),
                 feedtune.Spec(**spec_dict())):
        assert without_times(feedtune.tune(spec).to_json()) == expected, type(spec)


def test_a_spec_built_in_code_is_checked_as_a_file_is():
    """``Spec(...)`` checks the schema only; ``tune`` refuses what ``feedtune validate``
    refuses (an unknown tunable, a metric the plant does not define), naming each field."""
    data = spec_dict()
    data["tunables"]["nonsense"] = {"value": 1}
    data["objective"].append({"metric": "sensitivity"})
    spec = feedtune.Spec.model_validate(data)  # the schema alone lets it through
    with pytest.raises(feedtune.SpecError) as info:
        feedtune.tune(spec)
    pointers = [pointer for pointer, _ in info.value.errors]
    assert "/tunables/nonsense" in pointers and "/objective/1/metric" in pointers
    with pytest.raises(feedtune.SpecError) as from_dict:
        parse_spec(copy.deepcopy(data))
    assert info.value.errors == from_dict.value.errors


def test_bad_input_raises_spec_error_naming_the_field_never_system_exit():
    data = spec_dict()
    data["plant"]["time_constant"] = -1
    del data["objective"]
    with pytest.raises(feedtune.SpecError) as info:
        feedtune.tune(data)
    assert dict(info.value.errors).keys() >= {"/plant/time_constant", "/objective"}
    assert isinstance(info.value, ValueError)


def test_a_path_that_cannot_be_read_raises_the_os_error(tmp_path):
    with pytest.raises(FileNotFoundError):
        feedtune.tune(tmp_path / "missing.json")
    with pytest.raises(IsADirectoryError):
        feedtune.tune(tmp_path)
    big = tmp_path / "big.json"
    big.write_bytes(b" " * 1_000_001)
    with pytest.raises(feedtune.SpecError, match="larger than the limit"):
        feedtune.tune(big)
    with pytest.raises(TypeError, match="not bytes"):
        feedtune.tune(EXAMPLE.read_bytes())
    with pytest.raises(TypeError, match="for JSON text give json.loads"):
        feedtune.tune(EXAMPLE.read_text())


# -- the result object ---------------------------------------------------------------------

def test_the_result_says_what_the_json_holds(result):
    data = result.data
    assert (result.name, result.success, result.status) == (data.name, True, "optimal")
    assert result.values == {name: t.value for name, t in data.tuned.items()}
    assert result.units == {"position_gain": "1/s", "sampling_period": "s"}
    assert result.tuned["sampling_period"].fixed
    assert result.metrics["damping_ratio"].unit == "1"
    assert result.metrics is data.metrics and result.constraints is data.constraints
    assert result.constraints[0].satisfied
    assert result.objective == data.objective and result.message == data.message
    assert result.optimum is data.optimum and result.warnings == data.warnings
    assert result.validation["ok"] is True and result.stability["stable"] is True
    assert result.spec.name == "koren-1979-sampled-data"
    assert result.path is None


def test_repr_and_summary_are_readable(result):
    text = repr(result)
    assert text.startswith("<feedtune.Result 'koren-1979-sampled-data': optimal;")
    assert "position_gain=18.17" in text and "1/s" in text
    summary = result.summary()
    assert str(result) == summary
    assert summary.splitlines()[0].startswith("koren-1979-sampled-data: optimal — ")
    assert re.search(r"^  position_gain +18\.17\d* \[1/s\]$", summary, re.M)
    assert re.search(r"^  damping_ratio = 0\.\d+ \[1\]  \(min 0\.5\)  OK$", summary, re.M)


def test_a_failed_solve_is_a_result_not_an_exception():
    data = spec_dict()
    data["constraints"] = [{"metric": "damping_ratio", "min": 0.99}]
    data["tunables"]["position_gain"] = {"min": 100, "max": 200}
    failed = feedtune.tune(data)
    assert failed.success is False and failed.status != "optimal"
    assert "(not successful)" in repr(failed) and "(not successful)" in failed.summary()


def test_save_writes_to_json_atomically_and_load_result_reads_it_back(result, tmp_path):
    path = tmp_path / "result.json"
    assert result.save(path) == path
    assert path.read_text(encoding="utf-8") == result.to_json()
    assert result.to_json().endswith("}\n")
    assert [p.name for p in tmp_path.iterdir()] == ["result.json"]  # no temporary file left
    loaded = feedtune.load_result(path)
    assert isinstance(loaded, feedtune.Result)
    assert loaded.to_json() == result.to_json()  # the same bytes, times included
    assert loaded.path == path and "path='" in repr(loaded)


def test_save_replaces_a_symlink_never_follows_it(result, tmp_path):
    victim = tmp_path / "victim.txt"
    victim.write_text("keep me")
    link = tmp_path / "result.json"
    link.symlink_to(victim)
    result.save(link)
    assert victim.read_text() == "keep me"
    assert not link.is_symlink() and link.read_text() == result.to_json()


def test_load_result_refuses_what_is_not_a_result(tmp_path):
    path = tmp_path / "spec.json"
    path.write_bytes(EXAMPLE.read_bytes())
    with pytest.raises(ResultError, match="this is a spec, not a result") as info:
        feedtune.load_result(path)
    assert str(path) in str(info.value)
    assert feedtune.ResultError is ResultError


def test_to_control_names_the_signals(result):
    systems = result.to_control()
    assert systems.closed_loop.input_labels == ["reference"]
    assert systems.closed_loop.output_labels == ["position"]
    assert systems.open_loop.input_labels == ["error"]
    assert systems.error.output_labels == ["error"]
    assert systems.dt == result.values["sampling_period"]


def test_report_writes_the_page_and_figures(result, tmp_path, monkeypatch):
    """The four figures drawn without their final ``tight_layout`` (≈ 0.35 s of CPU the
    four, measuring every text): it moves the axes on the canvas, which nothing here reads;
    the laid-out figures are tests/unit/test_report.py's and the report commands'."""
    from matplotlib.figure import Figure

    monkeypatch.setattr(Figure, "tight_layout", lambda self, *args, **kwargs: None)
    written = result.report(tmp_path / "report")
    assert written.page == tmp_path / "report" / "report.html"
    assert [p.name for p in written.figures] == ["responses.png", "bode.png", "circle.png",
                                                 "poles.png"]
    assert written.left_out == {}
    assert all(p.read_bytes().startswith(b"\x89PNG") for p in written.figures)
    assert "koren-1979-sampled-data" in written.page.read_text(encoding="utf-8")


# -- BLAS threads -----------------------------------------------------------------------------

def blas_threads() -> set[int]:
    return {pool["num_threads"] for pool in threadpool_info() if pool["user_api"] == "blas"}


@pytest.mark.skipif(not blas_threads(), reason="no BLAS that threadpoolctl can see")
@pytest.mark.parametrize("threads", [1, None])
def test_threads_pin_blas_within_the_call_and_restore_it(monkeypatch, threads):
    """With a caller's BLAS on 2 threads, ``threads=1`` runs the tuning on one and gives the
    2 back; ``threads=None`` leaves them."""
    seen = []
    solve = feedtune.problem.tune

    def recording(*args, **kwargs):
        seen.append(blas_threads())
        return solve(*args, **kwargs)

    monkeypatch.setattr(feedtune.problem, "tune", recording)
    with threadpool_limits(limits=2, user_api="blas"):
        outer = blas_threads()
        if outer == {1}:
            pytest.skip("this BLAS runs one thread at most")
        feedtune.tune(spec_dict(multistart=1), threads=threads)
        assert blas_threads() == outer
    assert seen == [{1} if threads == 1 else outer]



def test_an_openblas_loaded_during_the_call_starts_on_the_calls_threads(monkeypatch):
    """OPENBLAS_NUM_THREADS is ``threads`` during the call (CasADi's own OpenBLAS, loaded
    with IPOPT's plugin at the first solve, reads it then) and unset again after; a
    caller's own value is left as it is."""
    seen = []
    solve = feedtune.problem.tune

    def recording(*args, **kwargs):
        seen.append(os.environ.get("OPENBLAS_NUM_THREADS"))
        return solve(*args, **kwargs)

    monkeypatch.setattr(feedtune.problem, "tune", recording)
    monkeypatch.delenv("OPENBLAS_NUM_THREADS", raising=False)
    feedtune.tune(spec_dict(multistart=1))
    assert "OPENBLAS_NUM_THREADS" not in os.environ
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "3")
    feedtune.tune(spec_dict(multistart=1))
    assert os.environ["OPENBLAS_NUM_THREADS"] == "3"
    feedtune.tune(spec_dict(multistart=1), threads=None)
    assert seen == ["1", "3", "3"]


@pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="threads counted in /proc")
def test_a_fresh_processs_first_tuning_starts_no_blas_worker_threads():
    """In a fresh process without thread variables (a Python caller's), the first tuning
    adds no thread: CasADi's OpenBLAS, loaded by it, starts on one (on main its worker
    spun ≈ 0.13 s of CPU on the other core of a cold user-drive tuning)."""
    code = ("import os, feedtune, feedtune.problem, json, sys\n"
            "before = len(os.listdir('/proc/self/task'))\n"
            "feedtune.tune(json.loads(sys.argv[1]))\n"
            "print(before, len(os.listdir('/proc/self/task')))")
    env = {k: v for k, v in os.environ.items()
           if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}
    out = subprocess.run([sys.executable, "-c", code, json.dumps(spec_dict(multistart=1))],
                         capture_output=True, text=True, env=env, cwd=REPO, check=True)
    before, after = map(int, out.stdout.split())
    assert after == before


# -- the garbage collector --------------------------------------------------------------------

def test_the_objects_before_the_call_are_left_out_of_the_collectors_scans_and_given_back(
        monkeypatch):
    """Within the call every object alive before it is frozen (``gc.freeze``: a fresh
    process's full collection walked the imports' ≈ 95 000 objects, 0.05-0.06 s of a cold
    tuning, benchmarks/README.md "Branch h-cold4"); after it nothing stays frozen, so the
    caller's garbage is collected as before."""
    before = [object()]  # a container the collector tracks, alive before the call
    seen = []
    solve = feedtune.problem.tune

    def recording(*args, **kwargs):
        listed = any(o is before for o in gc.get_objects())  # frozen ones are not listed
        seen.append((gc.get_freeze_count() > 0, listed))
        return solve(*args, **kwargs)

    monkeypatch.setattr(feedtune.problem, "tune", recording)
    assert gc.get_freeze_count() == 0 and any(o is before for o in gc.get_objects())
    feedtune.tune(spec_dict(multistart=1))
    assert seen == [(True, False)]
    assert gc.get_freeze_count() == 0 and any(o is before for o in gc.get_objects())


def test_a_callers_own_frozen_objects_stay_frozen():
    """A caller that froze objects itself (say before forking workers) keeps them frozen:
    the call neither freezes more nor unfreezes them."""
    kept = [object()]  # the caller's, frozen by the caller
    gc.freeze()
    try:
        feedtune.tune(spec_dict(multistart=1))
        assert gc.get_freeze_count() > 0
        assert not any(o is kept for o in gc.get_objects())  # still frozen: not listed
    finally:
        gc.unfreeze()


def test_a_root_search_is_summarised_by_its_evaluations_of_e(tuned):
    """Koren's reference-pulse example (one gain, one |e| minimised) is solved by the root
    search (feedtune/tuner/roots.py): the summary and each start's line name it and count
    evaluations of the signed e, which are not IPOPT iterations."""
    from feedtune.api import summary_lines
    from feedtune.cli.tune import _start_text

    spec = json.loads((REPO / "examples" / "koren-1979-reference-pulse.json").read_text(encoding="utf-8"))
    result = tuned(spec)
    assert result.solver.method == "root"
    line = summary_lines(result)[-1]
    assert line.startswith("solver: root search ")
    assert f"{result.solver.iterations} evaluations of e" in line
    root_start = next(s for s in result.solver.starts if s.method == "root")
    assert f"{root_start.iterations} evaluations of e" in _start_text(root_start)
