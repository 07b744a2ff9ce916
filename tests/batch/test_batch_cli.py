"""``feedtune batch`` through its real entry point, and its executors in process.

A batch whose process is the subject (a signal or SIGKILL sent to it, its Dask scheduler
lost or missing) runs as a process of its own forked from this one (``start_cli``,
tests/feedtune_cli.py), running the ``feedtune`` script's ``main``; a fresh interpreter
(``python -m feedtune``, ``python -c``) where its start is the subject: a signal while the
command line loads, what the warm-up imports, a batch without Dask installed, a worker
whose batch dies as it starts.

What issue 5 asks of a batch, each with a test that fails if it breaks: one result per
spec named after it (collisions handled) and a summary; resume by canonical-spec hash and
feedtune version; exit statuses 0/1/2; JUnit XML and GitHub annotations; the baseline
gate; a worker that dies or overruns charged to its spec alone; SIGKILL mid-run and a
rerun giving exactly an uninterrupted run's results with no partial file; and the same
results from 1 worker, all cores and a local Dask cluster.
"""

from __future__ import annotations

import contextlib
import json
import multiprocessing
import multiprocessing.process
import multiprocessing.util
import os
import signal
import subprocess
import sys
import threading
import time
import traceback
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

import batch_jobs
from feedtune.batch.job import solve
from feedtune.batch.local import WORKER_GC_THRESHOLD, LocalExecutor
from feedtune.batch.runner import run_batch
from feedtune_cli import run_cli, run_forked, start_cli

REPO = Path(__file__).resolve().parents[2]
EXAMPLES = REPO / "examples"
FAST = "koren-1979-sampled-data"  # ≈0.1 s to tune
#: for a test of what the batch's parent process decides (inputs, baseline, validation rows):
#: a second worker process would load the tuner again (≈ 1.4 s of CPU) for two specs. How
#: specs are shared among workers is tested on all cores (mixed_batch, resume) and across
#: executors (test_one_worker_all_cores_and_dask_give_identical_results).
ONE_WORKER = ("-j", "1")


def in_process(*args: str) -> subprocess.CompletedProcess:
    """``feedtune ARGS`` through the real entry point in this process (text out;
    tests/feedtune_cli.py), for every command whose subject is not its process: a
    ``tune``, a batch refused before it starts, and a batch's results, summary, table,
    JUnit, annotations, resume and baseline. A batch's workers are forked from this
    process as from ``python -m feedtune batch`` (:func:`feedtune.batch.local.start_method`;
    spawned if a Dask test left a thread running), after the warm-up, done once here."""
    return run_cli(*args, cwd=REPO, text=True)


def _send_outcome(send, function, args) -> None:
    try:
        send.send((True, function(*args)))
    except BaseException:  # noqa: BLE001 — the parent raises it, with this traceback
        send.send((False, traceback.format_exc()))


def in_a_fork(function, *args):
    """``function(*args)`` in a child forked from this process (its imports and warm-up
    inherited; spawned, as a batch's workers are, if this process runs other threads), its
    return value sent back; an exception there is raised here with the child's traceback.

    For a Dask client: its threads (distributed's offload pool, its IO loop) stay in the
    process that ran it for good, and in this process they would make every later batch
    here spawn its workers instead of forking them (:func:`feedtune.batch.local.start_method`;
    ≈ 2 s of CPU a spawned worker: the realistic batch, the untrusted-spec and bad-spec
    batches of the same xdist worker). A child forked here instead of a ``python -m
    feedtune`` process: ≈ 1.5 s of imports saved."""
    from feedtune.batch.local import start_method

    context = multiprocessing.get_context(start_method())
    receive, send = context.Pipe(duplex=False)
    child = context.Process(target=_send_outcome, args=(send, function, args))
    child.start()
    send.close()
    try:
        ok, value = receive.recv()
    finally:
        child.join()
    if not ok:
        raise AssertionError(f"in the forked child:\n{value}")
    return value


def example(name: str = FAST) -> dict:
    return json.loads((EXAMPLES / f"{name}.json").read_text())


def write_specs(directory: Path, count: int, start: int = 0) -> list[Path]:
    """``count`` distinct fast specs (the example with its gain box varied)."""
    directory.mkdir(parents=True, exist_ok=True)
    paths = []
    for i in range(start, start + count):
        spec = example()
        spec["name"] = f"axis-{i:03d}"
        spec["tunables"]["position_gain"] = {"min": 1.0, "max": 60.0 + 5 * i}
        spec["solver"] = {"multistart": 2}
        path = directory / f"axis-{i:03d}.json"
        path.write_text(json.dumps(spec))
        paths.append(path)
    return paths


def without_times(node):
    """A result or summary row without wall-clock fields (``*_time``, ``time``)."""
    if isinstance(node, dict):
        return {k: without_times(v) for k, v in node.items()
                if not (k.endswith("_time") or k == "time")}
    if isinstance(node, list):
        return [without_times(v) for v in node]
    return node


def results(out: Path) -> dict[str, dict]:
    """Every result file in ``out`` (not the summary), without times."""
    return {p.name: without_times(json.loads(p.read_text()))
            for p in sorted(out.glob("*.json")) if p.name != "summary.json"}


def summary(out: Path) -> dict:
    return json.loads((out / "summary.json").read_text())


def rows_by_id(out: Path) -> dict[str, dict]:
    return {row["id"]: row for row in summary(out)["rows"]}


@pytest.fixture(scope="module", autouse=True)
def threads_before() -> set[str]:
    """The names of this process's Python threads before the file's first test."""
    return {thread.name for thread in threading.enumerate()}


@pytest.fixture(scope="module")
def distributed_loaded() -> None:
    """distributed imported in this process (≈ 0.5 s of CPU, no thread started) before a
    Dask test forks its children (the client's process, a scheduler, a worker, a batch),
    so that each of them has it loaded instead of importing it again. No client runs here
    (in_a_fork; test_the_dask_tests_leave_no_thread_in_this_process)."""
    import distributed  # noqa: F401 — loaded for the children forked from this process


# -- one batch, read every way ------------------------------------------------------------

@pytest.fixture(scope="module")
def mixed_batch(tmp_path_factory):
    """Three good specs, one whose constraint cannot hold, two sharing a name, one
    invalid, run once through the CLI with JUnit and GitHub output."""
    root = tmp_path_factory.mktemp("mixed")
    specs = root / "specs"
    write_specs(specs, 3)
    impossible = example()
    impossible["name"] = "impossible"
    impossible["constraints"] = [{"metric": "damping_ratio", "min": 0.9},
                                 {"metric": "natural_frequency", "min": 500}]
    (specs / "impossible.json").write_text(json.dumps(impossible))
    twin = example()
    twin["name"] = "Axis-000"  # the first spec's name but for case: its own file
    (specs / "twin.json").write_text(json.dumps(twin))
    bad = example()
    bad["name"] = "zz-bad"
    bad["plant"]["time_constant"] = -0.02
    (specs / "zz-bad.json").write_text(json.dumps(bad))
    out = root / "out"
    proc = in_process("batch", str(specs), "--out", str(out), "--junit",
                      str(root / "junit.xml"), "--format", "github")
    return root, out, proc


def test_a_result_per_spec_named_after_it_and_a_summary(mixed_batch):
    _, out, proc = mixed_batch
    rows = rows_by_id(out)
    assert set(rows) == {"axis-000", "axis-001", "axis-002", "impossible", "Axis-000-2", "zz-bad"}
    assert rows["Axis-000-2"]["name"] == "Axis-000"  # case-insensitive collision → suffix
    for stem in ("axis-000", "axis-001", "axis-002", "impossible", "Axis-000-2"):
        assert rows[stem]["result"] == f"{stem}.json"
        assert (out / f"{stem}.json").is_file()
    assert rows["zz-bad"]["result"] is None and not (out / "zz-bad.json").exists()
    assert [r["id"] for r in summary(out)["rows"]] == [  # input order: directory sorted
        "axis-000", "axis-001", "axis-002", "impossible", "Axis-000-2", "zz-bad"]
    ok = {stem: row["ok"] for stem, row in rows.items()}
    assert ok == {"axis-000": True, "axis-001": True, "axis-002": True, "impossible": False,
                  "Axis-000-2": True, "zz-bad": False}
    assert rows["axis-001"]["tuned"]["position_gain"] > 0
    assert rows["axis-001"]["objective"] == json.loads(
        (out / "axis-001.json").read_text())["objective"]
    assert "Traceback" not in proc.stderr


def test_exit_status_one_and_a_table_naming_the_failures(mixed_batch):
    _, _, proc = mixed_batch
    assert proc.returncode == 1, proc.stderr
    assert "6 specs: 4 ok, 2 failed" in proc.stderr
    table = {line.split()[0]: line for line in proc.stderr.splitlines()
             if line and line.split()[0] in {"axis-000", "impossible", "zz-bad"}}
    assert table["axis-000"].rstrip().endswith("ok")
    assert "FAIL" in table["impossible"] and "infeasible" in table["impossible"]
    assert "FAIL" in table["zz-bad"] and "/plant/time_constant" in table["zz-bad"]


def test_a_batch_result_is_what_feedtune_tune_writes(mixed_batch, tmp_path):
    _, out, _ = mixed_batch
    spec = out.parent / "specs" / "axis-001.json"
    proc = in_process("tune", str(spec), "-o", str(tmp_path / "single.json"))
    assert proc.returncode == 0, proc.stderr
    single = without_times(json.loads((tmp_path / "single.json").read_text()))
    assert results(out)["axis-001.json"] == single


def test_junit_has_a_case_per_spec_failing_the_bad_ones(mixed_batch):
    root, _, _ = mixed_batch
    suite = ET.parse(root / "junit.xml").getroot().find("testsuite")
    cases = {case.get("name"): case for case in suite.iter("testcase")}
    assert set(cases) == {"axis-000", "axis-001", "axis-002", "impossible", "Axis-000-2", "zz-bad"}
    failed = {name for name, case in cases.items() if case.find("failure") is not None}
    assert failed == {"impossible", "zz-bad"}
    assert suite.get("tests") == "6" and suite.get("failures") == "2"
    assert cases["zz-bad"].find("failure").get("type") == "invalid"
    assert cases["zz-bad"].get("file").endswith("zz-bad.json")


def test_a_spec_failing_only_validation_says_metric_values_and_tolerance(tmp_path):
    """A result whose radial error the re-simulation contradicts (its block edited, then
    resumed): the row, the table, the JUnit failure and the annotation name the metric,
    both values, the gap and the tolerance, in the words of `feedtune tune`'s warning."""
    from feedtune.validate import warning_lines

    specs, out = tmp_path / "specs", tmp_path / "out"
    write_specs(specs, 2)
    assert in_process("batch", str(specs), "--out", str(out), *ONE_WORKER).returncode == 0
    result = json.loads((out / "axis-001.json").read_text())
    block = result["validation"]
    entry = next(e for e in block["entries"] if e["metric"] == "radial_error")
    entry.update(validated=entry["reported"] + 2e-9, gap=2e-9, tolerance=1e-10, ok=False)
    block["ok"] = False
    (out / "axis-001.json").write_text(json.dumps(result, indent=2))
    proc = in_process("batch", str(specs), "--out", str(out), "--junit",
                      str(tmp_path / "junit.xml"), "--format", "github", *ONE_WORKER)
    assert proc.returncode == 1, proc.stderr
    row = rows_by_id(out)["axis-001"]
    (said,) = [line.removeprefix("warning: ") for line in warning_lines(block)]
    assert said.startswith("validation: radial_error(radius=0.008,feed=0.04) reported ")
    assert "re-simulated" in said and "2e-09" in said and "tolerance 1e-10" in said
    assert row["resumed"] and not row["ok"] and row["reason"] == "validation"
    assert row["message"] == said and row["validation_failures"] == [said]
    assert rows_by_id(out)["axis-000"]["ok"]
    assert any(line.startswith("axis-001") and said in line for line in proc.stderr.splitlines())
    case = next(c for c in ET.parse(tmp_path / "junit.xml").getroot().iter("testcase")
                if c.get("name") == "axis-001")
    assert case.find("failure").get("type") == "validation"
    assert case.find("failure").get("message") == said
    (annotation,) = proc.stdout.splitlines()
    assert annotation.endswith("title=feedtune%3A axis-001 validation::" + said)


def test_github_annotations_name_each_failing_spec_file(mixed_batch):
    _, _, proc = mixed_batch
    lines = [line for line in proc.stdout.splitlines() if not line.startswith("::warning ")]
    assert len(lines) == 2 and all(line.startswith("::error file=") for line in lines)
    assert any("zz-bad.json" in line and "/plant/time_constant" in line for line in lines)
    assert any("impossible.json" in line and "infeasible" in line for line in lines)
    assert all("\n" not in line for line in lines)


# -- resume -------------------------------------------------------------------------------

def test_a_rerun_skips_solved_specs_and_solves_changed_ones(tmp_path):
    specs = tmp_path / "specs"
    write_specs(specs, 3)
    out = tmp_path / "out"
    first = in_process("batch", str(specs), "--out", str(out))
    assert first.returncode == 0, first.stderr
    stamps = {p.name: p.stat().st_mtime_ns for p in out.glob("axis-*.json")}
    changed = json.loads((specs / "axis-002.json").read_text())
    changed["tunables"]["position_gain"]["max"] = 30.0
    (specs / "axis-002.json").write_text(json.dumps(changed, indent=4))
    (specs / "axis-000.json").write_text(  # same spec, other formatting: same canonical hash
        json.dumps(json.loads((specs / "axis-000.json").read_text()), indent=8))
    second = in_process("batch", str(specs), "--out", str(out))
    assert second.returncode == 0, second.stderr
    rows = rows_by_id(out)
    assert [rows[f"axis-00{i}"]["resumed"] for i in range(3)] == [True, True, False]
    assert (out / "axis-000.json").stat().st_mtime_ns == stamps["axis-000.json"]
    assert (out / "axis-002.json").stat().st_mtime_ns != stamps["axis-002.json"]
    assert json.loads((out / "axis-002.json").read_text())["spec"]["tunables"][
        "position_gain"]["max"] == 30.0
    assert rows["axis-000"]["objective"] is not None and rows["axis-000"]["ok"]


def test_a_result_of_another_feedtune_version_is_solved_again(tmp_path):
    specs = tmp_path / "specs"
    write_specs(specs, 1)
    out = tmp_path / "out"
    assert in_process("batch", str(specs), "--out", str(out)).returncode == 0
    result = json.loads((out / "axis-000.json").read_text())
    result["provenance"]["feedtune"] = "0.0.0-older"
    (out / "axis-000.json").write_text(json.dumps(result))
    assert in_process("batch", str(specs), "--out", str(out)).returncode == 0
    assert rows_by_id(out)["axis-000"]["resumed"] is False
    assert json.loads((out / "axis-000.json").read_text())["provenance"]["feedtune"] != "0.0.0-older"


# -- unusable inputs: exit 2 --------------------------------------------------------------

@pytest.mark.parametrize("case", ["missing", "empty-dir", "no-match", "out-is-file",
                                  "no-baseline", "not-a-spec"])
def test_unusable_inputs_exit_two_naming_them(tmp_path, case):
    specs = tmp_path / "specs"
    write_specs(specs, 1)
    out, args = tmp_path / "out", None
    if case == "missing":
        args, named = [str(tmp_path / "nope.json")], "nope.json: no such file"
    elif case == "empty-dir":
        (tmp_path / "empty").mkdir()
        args, named = [str(tmp_path / "empty")], "holds no *.json"
    elif case == "no-match":
        args, named = [str(tmp_path / "*.yaml.json")], "pattern matches no"
    elif case == "out-is-file":
        out.write_text("x")
        args, named = [str(specs)], "is not a directory"
    elif case == "no-baseline":
        args, named = [str(specs), "--baseline", str(tmp_path / "old")], "summary.json: no such file"
    else:
        (tmp_path / "notes.txt").write_text("{}")
        args, named = [str(tmp_path / "notes.txt")], "not a spec file"
    proc = in_process("batch", *args, "--out", str(out))
    assert proc.returncode == 2, proc.stderr
    assert named in proc.stderr and "Traceback" not in proc.stderr
    assert not (out / "summary.json").exists()


def tree(root: Path) -> dict[str, bytes | None]:
    """Every file (its bytes) and directory (None) below ``root``."""
    return {str(p.relative_to(root)): p.read_bytes() if p.is_file() else None
            for p in sorted(root.rglob("*"))}


@pytest.mark.parametrize("case", ["out-is-input", "out-inside-input", "link-to-input",
                                  "dir-of-file-input", "matched-by-pattern"])
def test_an_output_directory_where_inputs_are_read_is_refused(tmp_path, case):
    """The issue's `batch specs --out specs` (overwrote every spec, exit 0) and `--out
    specs/results` (a rerun read its results as specs), and the same through a symbolic
    link, a file input's directory and a pattern's base: exit 2 naming both, nothing
    written."""
    specs = tmp_path / "specs"
    write_specs(specs, 2)
    inputs, out = [str(specs)], specs
    if case == "out-inside-input":
        out = specs / "results"
    elif case == "link-to-input":
        out = tmp_path / "link"
        out.symlink_to(specs, target_is_directory=True)
    elif case == "dir-of-file-input":
        inputs = [str(specs / "axis-001.json")]
    elif case == "matched-by-pattern":
        inputs, out = [str(specs / "**" / "*.json")], specs / "nested" / "results"
    before = tree(tmp_path)
    proc = in_process("batch", *inputs, "--out", str(out))
    assert proc.returncode == 2, proc.stderr
    (line,) = proc.stderr.splitlines()
    assert line.startswith(f"error: --out {out} ") and f" {inputs[0]}: " in line, line
    assert tree(tmp_path) == before  # inputs untouched, no directory, lock or summary made


def test_an_output_directory_beside_the_inputs_is_accepted(tmp_path):
    from feedtune.batch.inputs import check_output_apart

    specs = tmp_path / "specs"
    write_specs(specs, 1)
    check_output_apart([str(specs / "axis-000.json")], specs / "results")  # not read again
    check_output_apart([str(specs), str(specs / "*.json")], tmp_path / "specs-results")


@pytest.mark.parametrize("pattern, out, refused", [
    ("specs/*.json", "specs", True),
    ("specs/*.json", "specs/results", False),  # one level too deep for the pattern
    ("*/*.json", "results", True),  # results/NAME.json would match on a rerun
    ("specs/**/*.json", "specs/a/b", True),
    ("specs/*/x.json", "specs", False),
    ("specs/a*/*.json", "specs/b", False),
    ("other/*.json", "specs", False),
])
def test_a_pattern_refuses_an_output_directory_whose_files_it_would_match(
        tmp_path, monkeypatch, pattern, out, refused):
    from feedtune.batch.inputs import InputError, check_output_apart

    monkeypatch.chdir(tmp_path)
    if refused:
        with pytest.raises(InputError, match=f"--out {out} holds files matched by the input"):
            check_output_apart([pattern], Path(out))
    else:
        check_output_apart([pattern], Path(out))


def test_glob_patterns_and_jsonl_inputs(tmp_path):
    specs = tmp_path / "specs"
    write_specs(specs, 2)
    lines = [json.dumps({**example(), "name": f"line-{i}"}) for i in range(2)]
    (tmp_path / "more.jsonl").write_text(lines[0] + "\n\n" + lines[1] + "\n")
    out = tmp_path / "out"
    proc = in_process("batch", str(specs / "*.json"), str(tmp_path / "more.jsonl"), "--out",
                      str(out), *ONE_WORKER)
    assert proc.returncode == 0, proc.stderr
    rows = rows_by_id(out)
    assert set(rows) == {"axis-000", "axis-001", "line-0", "line-1"}
    assert rows["line-1"]["input"].endswith("more.jsonl:3") and rows["line-1"]["line"] == 3


# -- baseline -----------------------------------------------------------------------------

def test_baseline_fails_a_spec_whose_objective_got_worse(tmp_path):
    specs = tmp_path / "specs"
    write_specs(specs, 2)
    before = tmp_path / "before"
    assert in_process("batch", str(specs), "--out", str(before), *ONE_WORKER).returncode == 0
    worse = json.loads((specs / "axis-001.json").read_text())
    # the optimum gain of the example exceeds 20: capping it raises the objective
    worse["tunables"]["position_gain"]["max"] = 20.0
    (specs / "axis-001.json").write_text(json.dumps(worse))
    after = tmp_path / "after"
    proc = in_process("batch", str(specs), "--out", str(after), "--baseline", str(before),
                      "--junit", str(tmp_path / "j.xml"), *ONE_WORKER)
    rows = rows_by_id(after)
    assert rows["axis-001"]["status"] == "optimal"
    assert rows["axis-001"]["baseline"]["verdict"] == "worse", rows["axis-001"]
    assert not rows["axis-001"]["ok"] and rows["axis-000"]["ok"]
    assert rows["axis-000"]["baseline"]["verdict"] == "same"
    assert proc.returncode == 1
    assert "worse than the baseline" in proc.stderr
    again = in_process("batch", str(specs), "--out", str(tmp_path / "again"), "--baseline",
                       str(after), *ONE_WORKER)
    assert again.returncode == 0, again.stderr  # the same results: nothing got worse


# -- failures inside the executor ---------------------------------------------------------

def _tasks(directory: Path, marks: dict[str, bytes]) -> list[Path]:
    paths = write_specs(directory, 4)
    for name, mark in marks.items():
        spec = example()
        spec["name"] = name
        spec["description"] = mark.decode()
        (directory / f"{name}.json").write_text(json.dumps(spec))
    return paths


def test_a_worker_that_dies_is_charged_to_its_spec_alone(tmp_path):
    _tasks(tmp_path / "specs", {"axis-crash": batch_jobs.CRASH_MARK})
    outcome = run_batch([str(tmp_path / "specs")], tmp_path / "out",
                        LocalExecutor(2, job=batch_jobs.crashing))
    rows = {row["id"]: row for row in outcome.document["rows"]}
    assert rows["axis-crash"]["status"] == "worker_died"
    assert "SIGKILL" in rows["axis-crash"]["message"]
    assert [rows[f"axis-00{i}"]["status"] for i in range(4)] == ["optimal"] * 4


def test_a_spec_over_the_time_limit_is_stopped_and_the_rest_complete(tmp_path):
    _tasks(tmp_path / "specs", {"axis-hang": batch_jobs.SLEEP_MARK})
    started = time.monotonic()
    outcome = run_batch([str(tmp_path / "specs")], tmp_path / "out",
                        LocalExecutor(2, timeout=3.0, job=batch_jobs.sleeping))
    rows = {row["id"]: row for row in outcome.document["rows"]}
    assert rows["axis-hang"]["status"] == "timeout"
    assert [rows[f"axis-00{i}"]["status"] for i in range(4)] == ["optimal"] * 4
    assert time.monotonic() - started < 50  # not the 60 s the job sleeps


@pytest.fixture(scope="module")
def first_spec_facts(tmp_path_factory):
    """``facts(start)``: what a worker started by ``start`` had before each of its two specs'
    clocks started (batch_jobs.first_spec_facts' messages), from one batch of two specs per
    start method, run when first asked and read by the two tests below (a spawned worker
    is a fresh interpreter: ≈ 0.8 s of CPU a batch)."""
    messages = {}

    def facts(start: str) -> list[str]:
        if start not in messages:
            root = tmp_path_factory.mktemp(f"first-spec-{start}")
            write_specs(root / "specs", 2)
            outcome = run_batch([str(root / "specs")], root / "out",
                                LocalExecutor(1, job=batch_jobs.first_spec_facts, start=start))
            messages[start] = [row["message"] for row in outcome.document["rows"]]
        return messages[start]

    return facts


@pytest.mark.parametrize("start", ["fork", "spawn"])
def test_a_worker_loads_the_tuner_before_the_clock_of_its_first_spec_starts(first_spec_facts,
                                                                           start):
    """--timeout charges a spec its own time, not its worker's start (loading CasADi took
    over the test's 3 s limit on a loaded machine: every spec timed out; a spawned worker's
    first tuning, ≈ 0.8 s of CPU more, did so at load 9). A worker is forked, or spawned
    when the batch's process runs other threads (test_workers_are_spawned_while_...)."""
    assert [message.split("; ")[0] for message in first_spec_facts(start)] == [
        "tuner loaded before the spec: True, warmed up: True"] * 2


@pytest.mark.parametrize("start", ["fork", "spawn"])
def test_a_worker_freezes_what_it_loaded_before_its_first_spec(first_spec_facts, start):
    """Issue 15: the imports and the warm-up's objects (≈ 74 000) are left out of a worker's
    garbage collections, which walked them at every full collection and, forked, copied the
    pages it shares with the batch (benchmarks/README.md, "Branch h-bx1")."""
    assert [message.split("; ")[1] for message in first_spec_facts(start)] == [
        "objects frozen before the spec: True"] * 2


@pytest.mark.parametrize("start", ["fork", "spawn"])
def test_a_worker_collects_its_young_objects_less_often(first_spec_facts, start):
    """Issue 15: a worker's young generation holds WORKER_GC_THRESHOLD objects before a
    collection, not CPython's 700 (≈ 0.7 collections a batch spec, the same cycles freed
    a few specs later; benchmarks/README.md, "Branch h-bval6")."""
    assert WORKER_GC_THRESHOLD > 700
    assert [message.split("; ")[2] for message in first_spec_facts(start)] == [
        f"young-generation threshold: {WORKER_GC_THRESHOLD}"] * 2


def test_workers_are_forked_from_this_process_with_what_it_loaded(tmp_path, monkeypatch):
    """Issue 15: a worker starts as a copy of the batch's process (the tuner imported once,
    here), not as a fresh interpreter importing CasADi and scipy again (≈ 0.9 s CPU each)."""
    monkeypatch.setattr(batch_jobs, "PARENT_MARK", "set in the parent")
    write_specs(tmp_path / "specs", 3)
    outcome = run_batch([str(tmp_path / "specs")], tmp_path / "out",
                        LocalExecutor(2, job=batch_jobs.parent_mark))
    assert [row["message"] for row in outcome.document["rows"]] == [
        "parent mark: set in the parent"] * 3


@pytest.mark.skipif(not Path("/proc/self/fd").exists(), reason="reads /proc (Linux)")
def test_a_forked_worker_does_not_hold_the_batch_lock(tmp_path):
    """The lock is the batch process's alone: a worker forked while it is held had it too,
    so after a SIGKILL of the batch a rerun found the directory locked until the orphaned
    workers had died as well ("another feedtune batch is writing to this directory")."""
    write_specs(tmp_path / "specs", 2)
    outcome = run_batch([str(tmp_path / "specs")], tmp_path / "out",
                        LocalExecutor(1, job=batch_jobs.lock_descriptors, start="fork"))
    assert [row["message"] for row in outcome.document["rows"]] == ["lock descriptors: 0"] * 2


#: one fresh interpreter in which Dask's ``distributed`` cannot be imported, as without the
#: `dask` extra. First the warm-up check: after ``warm_up``, each spec of argv[1] (JSON)
#: solved, and the modules its solve loaded beyond those (a line "warm: STATUS [MODULES]");
#: then each ``feedtune`` command of argv[2] (JSON argument lists) through the real entry
#: point (tests/feedtune_cli.py, imported only after the check), its status and stderr (a
#: line "command: " and their JSON)
FRESH_WITHOUT_DASK = """
import json, sys
sys.modules["distributed"] = None  # not installed: importing it raises ImportError
from feedtune.batch.job import solve, warm_up
warm_up()
for spec in json.loads(sys.argv[1]):
    before = set(sys.modules)
    outcome = solve(json.dumps(spec).encode())
    print("warm:", outcome.status, sorted(set(sys.modules) - before))
sys.path.insert(0, sys.argv[3])
from feedtune_cli import run_cli
for args in json.loads(sys.argv[2]):
    done = run_cli(*args, text=True)
    print("command: " + json.dumps([done.returncode, done.stderr]))
"""

#: the batches run without Dask installed: the Dask executor, a scheduler's address, the
#: local executor
WITHOUT_DASK = {"dask": ["--executor", "dask"], "scheduler": ["--scheduler", "tcp://127.0.0.1:9"],
                "local": ["-j", "1"]}


@pytest.fixture(scope="module")
def fresh_without_dask(tmp_path_factory):
    """One fresh interpreter (``python -c FRESH_WITHOUT_DASK``) for the warm-up check and the
    batches without Dask, each of which had an interpreter of its own (≈ 1.5 s of CPU
    each in imports): {"warm": the check's lines, CASE: (the batch's status, its stderr,
    its --out directory)} for each case of WITHOUT_DASK. The check comes first, so that
    what a solve loads beyond the warm-up is a fresh interpreter's; the batches' command
    line and executors are imported after it, with ``distributed`` still blocked."""
    pulse, sampled = example("koren-1979-reference-pulse"), example()
    sampled["tunables"]["sampling_period"] = {"min": 0.002, "max": 0.05}
    sampled["solver"] = {"multistart": 3}
    root = tmp_path_factory.mktemp("without-dask")
    commands, outs = [], {}
    for case, args in WITHOUT_DASK.items():
        specs, outs[case] = root / case / "specs", root / case / "out"
        write_specs(specs, 1)
        commands.append(["batch", str(specs), "--out", str(outs[case]), *args])
    done = subprocess.run([sys.executable, "-c", FRESH_WITHOUT_DASK, json.dumps([pulse, sampled]),
                           json.dumps(commands), str(REPO / "tests")],
                          capture_output=True, text=True, timeout=300, cwd=REPO)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    ran = [json.loads(line.removeprefix("command: ")) for line in lines
           if line.startswith("command: ")]
    assert len(ran) == len(WITHOUT_DASK), done.stdout
    return {"warm": [line.removeprefix("warm: ") for line in lines if line.startswith("warm: ")],
            **{case: (*outcome, outs[case]) for case, outcome in zip(WITHOUT_DASK, ran)}}


def test_the_warm_up_loads_everything_a_software_servo_spec_loads(fresh_without_dask):
    """What the workers are forked with: after warm_up, tuning Koren's specs (another
    technique, a free sampling period, more starts) imports no further module, so no
    worker pays for imports on its first spec's clock (in a fresh interpreter:
    fresh_without_dask, before its batches)."""
    assert fresh_without_dask["warm"] == ["optimal []", "optimal []"]


def test_workers_are_spawned_while_another_thread_runs():
    """A lock held by another thread at a fork would stay held in the worker forever."""
    from feedtune.batch.local import start_method

    assert start_method() == "fork"  # Linux, this test's thread alone
    release = threading.Event()
    thread = threading.Thread(target=release.wait)
    thread.start()
    try:
        assert start_method() == "spawn"
    finally:
        release.set()
        thread.join()
    assert start_method() == "fork"


def test_a_forked_worker_ends_on_sigterm_whatever_handler_the_batch_had(tmp_path):
    """The batch's process holds SIGTERM back while it writes a result; its forked workers
    must not inherit that: SIGTERM ends a worker, charged to its spec."""
    _tasks(tmp_path / "specs", {"axis-term": batch_jobs.TERM_MARK})
    previous = signal.signal(signal.SIGTERM, lambda signum, frame: None)
    try:
        outcome = run_batch([str(tmp_path / "specs")], tmp_path / "out",
                            LocalExecutor(2, timeout=40.0, job=batch_jobs.terminated))
    finally:
        signal.signal(signal.SIGTERM, previous)
    rows = {row["id"]: row for row in outcome.document["rows"]}
    assert rows["axis-term"]["status"] == "worker_died"
    assert "SIGTERM" in rows["axis-term"]["message"]
    assert [rows[f"axis-00{i}"]["status"] for i in range(4)] == ["optimal"] * 4


def test_a_spec_over_its_own_ipopt_time_limit_is_a_row_and_the_rest_complete(tmp_path):
    write_specs(tmp_path / "specs", 2)
    slow = example("koren-1979-min-iae-radius")  # builds and solves for ≈ 0.7 s
    slow["name"] = "axis-slow"
    slow["solver"] = {"multistart": 1, "time_limit": 0.001}
    (tmp_path / "specs" / "axis-slow.json").write_text(json.dumps(slow))
    outcome = run_batch([str(tmp_path / "specs")], tmp_path / "out", LocalExecutor(1))
    rows = {row["id"]: row for row in outcome.document["rows"]}
    assert rows["axis-slow"]["status"] == "time_limit" and not rows["axis-slow"]["ok"]
    assert "Maximum_WallTime_Exceeded" in rows["axis-slow"]["message"]
    assert rows["axis-slow"]["result"] == "axis-slow.json"  # the unsolved result is kept
    assert [rows[f"axis-00{i}"]["status"] for i in range(2)] == ["optimal"] * 2


def test_a_non_unique_optimum_and_an_implausible_design_are_said_but_fail_nothing(tmp_path):
    """Issue 14 items 4 and 5 in the batch: the row, the table, the JUnit case and a GitHub
    ``::warning`` say them; the spec is still ok (exit 0)."""
    spec = example("koren-1979-sampled-data")
    spec["name"] = "flat"
    spec["tunables"] = {"position_gain": {"min": 1, "max": 200},
                        "sampling_period": {"min": 0.001, "max": 0.02}}
    spec["constraints"] = []
    spec["objective"][0]["radius"] = 0.005  # below the loop's minimum radius at V_m
    (tmp_path / "specs").mkdir()
    (tmp_path / "specs" / "flat.json").write_text(json.dumps(spec))
    proc = in_process("batch", str(tmp_path / "specs"), "--out", str(tmp_path / "out"),
                      "--format", "github", "--junit", str(tmp_path / "junit.xml"))
    assert proc.returncode == 0, proc.stderr
    (row,) = json.loads((tmp_path / "out" / "summary.json").read_text())["rows"]
    assert row["ok"] is True and row["optimum_unique"] is False
    assert row["notes"][0] == ("optimum not unique: the objective does not decide "
                               "position_gain, sampling_period")
    assert any(n.startswith("implausible: min_radius") for n in row["notes"])
    assert "optimum not unique" in proc.stderr  # the table
    warnings = [line for line in proc.stdout.splitlines() if line.startswith("::warning ")]
    assert len(warnings) == len(row["notes"]) and not any(
        line.startswith("::error") for line in proc.stdout.splitlines())
    junit = (tmp_path / "junit.xml").read_text()
    assert "optimum not unique" in junit and "<failure" not in junit


# -- SIGKILL and identical executors ------------------------------------------------------

@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory):
    """12 specs and their results from one uninterrupted ``batch -j 1`` (in this process):
    what a rerun after SIGKILL (all 12), all cores and Dask (the first 6) and a scheduler
    given by address (the first 3) must give. One batch for the three tests (issue 15)."""
    root = tmp_path_factory.mktemp("uninterrupted")
    specs, out = root / "specs", root / "out"
    paths = write_specs(specs, 12)
    proc = in_process("batch", str(specs), "--out", str(out), "-j", "1")
    assert proc.returncode == 0, proc.stderr
    return specs, paths, out


def first(count: int, out: Path, paths: list[Path]) -> tuple[dict[str, dict], list[dict]]:
    """The results and summary rows of ``uninterrupted`` for its first ``count`` specs
    (rows in input order: the same as a batch of those spec files alone)."""
    names = {path.name for path in paths[:count]}
    kept = {name: result for name, result in results(out).items() if name in names}
    assert len(kept) == count
    return kept, summary(out)["rows"][:count]


def test_sigkill_mid_run_then_rerun_gives_an_uninterrupted_runs_results(tmp_path, uninterrupted):
    specs, _, reference = uninterrupted
    out = tmp_path / "out"
    process = start_cli("batch", str(specs), "--out", str(out), "-j", "1", cwd=REPO)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and len(list(out.glob("axis-*.json"))) < 3:
        time.sleep(0.02)
    process.send_signal(signal.SIGKILL)
    process.wait()
    written = list(out.glob("axis-*.json"))
    assert 3 <= len(written) < 12, "the kill should land mid-run"
    for path in written:  # every file there is whole
        json.loads(path.read_text())
    rerun = in_process("batch", str(specs), "--out", str(out), "-j", "1")
    assert rerun.returncode == 0, rerun.stderr
    assert results(out) == results(reference)
    rows = rows_by_id(out)
    assert sum(row["resumed"] for row in rows.values()) >= len(written)
    assert without_times([{k: v for k, v in r.items() if k != "resumed"} for r in rows.values()]) == \
        without_times([{k: v for k, v in r.items() if k != "resumed"}
                       for r in rows_by_id(reference).values()])
    assert not [p for p in out.iterdir() if p.name.endswith(".tmp")]


def _on_local_dask_clusters(specs: list[str], out: Path, crash_specs: Path,
                            crash_out: Path):
    """(``feedtune batch SPECS --out OUT --executor dask -j 2``, the outcome of a batch of
    ``crash_specs`` on a local cluster of two workers whose job kills its worker on the
    spec marked so): the two local Dask clusters of this file, one after the other in this
    process, so that their worker processes come from one forkserver (it imports
    distributed and warms the tuner up: ≈ 3 s of CPU, which a second child forked here
    paid again; feedtune.batch.dask_cluster.warm_worker_processes)."""
    import dask

    from feedtune.batch.dask_cluster import DaskExecutor

    proc = in_process("batch", *specs, "--out", str(out), "--executor", "dask", "-j", "2")
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
        outcome = run_batch([str(crash_specs)], crash_out,
                            DaskExecutor(workers=2, job=batch_jobs.crashing))
    return proc, outcome


@pytest.fixture(scope="module")
def local_dask_clusters(tmp_path_factory, uninterrupted, distributed_loaded):
    """The local Dask clusters' batches (_on_local_dask_clusters), run in one child forked
    from this process (a Dask client would leave its threads in this process: in_a_fork):
    {"all-cores": (out, process) of the first 6 specs of ``uninterrupted`` on two Dask
    workers, "worker-died": the outcome of four good specs and one whose worker dies}."""
    root = tmp_path_factory.mktemp("dask-local")
    _, paths, _ = uninterrupted
    _tasks(root / "crash-specs", {"axis-crash": batch_jobs.CRASH_MARK})
    proc, outcome = in_a_fork(_on_local_dask_clusters, [str(path) for path in paths[:6]],
                              root / "dask", root / "crash-specs", root / "crash-out")
    return {"all-cores": (root / "dask", proc), "worker-died": outcome}


def test_one_worker_all_cores_and_dask_give_identical_results(tmp_path, uninterrupted,
                                                              local_dask_clusters):
    _, paths, reference = uninterrupted
    specs = [str(path) for path in paths[:6]]
    one, one_rows = first(6, reference, paths)  # one worker: `batch -j 1`
    outs = {"all": tmp_path / "all"}
    # all cores: the local executor's workers, forked here; Dask's cluster from a child
    # forked here (local_dask_clusters)
    outs["dask"], dask_proc = local_dask_clusters["all-cores"]
    for label, proc in (("all", in_process("batch", *specs, "--out", str(outs["all"]))),
                        ("dask", dask_proc)):
        assert proc.returncode == 0, (label, proc.stderr)
    assert len(one) == 6
    assert one == results(outs["all"]) == results(outs["dask"])
    rows = {label: without_times(summary(out)["rows"]) for label, out in outs.items()}
    assert without_times(one_rows) == rows["all"] == rows["dask"]
    assert summary(outs["dask"])["executor"] == "dask"


def test_a_second_batch_on_the_same_directory_is_refused(tmp_path):
    import fcntl

    from feedtune.batch.runner import LOCK_NAME

    specs = tmp_path / "specs"
    write_specs(specs, 1)
    out = tmp_path / "out"
    out.mkdir()
    with open(out / LOCK_NAME, "a+") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        proc = in_process("batch", str(specs), "--out", str(out))
    assert proc.returncode == 2 and "another feedtune batch" in proc.stderr


def test_solve_reports_an_invalid_spec_by_pointer_and_never_raises():
    outcome = solve(b'{"name": "x", "plant": {"type": "software_servo"}}')
    assert outcome.status == "invalid"
    assert any(pointer.startswith("/plant") or pointer == "/objective"
               for pointer, _ in outcome.errors)


@pytest.mark.parametrize("stop", [signal.SIGINT, signal.SIGTERM], ids=["ctrl-c", "sigterm"])
def test_interrupt_keeps_what_is_done_and_a_rerun_finishes(tmp_path, stop):
    specs = tmp_path / "specs"
    write_specs(specs, 10)
    out = tmp_path / "out"
    process = start_cli("batch", str(specs), "--out", str(out), "-j", "1", cwd=REPO, text=True)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and len(list(out.glob("axis-*.json"))) < 2:
        time.sleep(0.02)
    process.send_signal(stop)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 130, err
    assert "rerun the same command" in err and "Traceback" not in err
    rows = rows_by_id(out)
    done = [r for r in rows.values() if r["status"] != "not_run"]
    assert 2 <= len(done) < 10 and all(r["result"] for r in done)
    assert all(not r["ok"] for r in rows.values() if r["status"] == "not_run")
    assert in_process("batch", str(specs), "--out", str(out), "-j", "1").returncode == 0
    assert len(results(out)) == 10


def _batch_on_a_running_cluster(*args: str) -> tuple[str, subprocess.CompletedProcess]:
    """(scheduler address, ``feedtune batch ARGS --scheduler ADDRESS``) with a Dask cluster
    of one single-threaded worker listening on TCP running meanwhile (started first,
    stopped last). The worker is a thread of this process (already warm, a forked child
    of the test process), not a fresh interpreter loading the tuner again (≈ 3 s of CPU):
    what is tested is the batch joining a scheduler at an address, not its worker's
    process (a Dask worker process is tested by the executors' comparison and a worker's
    death)."""
    from distributed import LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp",
                      dashboard_address=None) as cluster:
        return cluster.scheduler_address, in_process(
            "batch", *args, "--scheduler", cluster.scheduler_address)


@pytest.mark.usefixtures("distributed_loaded")
def test_an_existing_dask_scheduler_by_address(tmp_path, uninterrupted):
    _, paths, reference = uninterrupted
    local, _ = first(3, reference, paths)  # the local executor's results
    # the cluster and the batch joining it, both in a child forked from this process
    address, proc = in_a_fork(_batch_on_a_running_cluster, *[str(path) for path in paths[:3]],
                              "--out", str(tmp_path / "remote"))
    assert proc.returncode == 0, proc.stderr
    assert summary(tmp_path / "remote")["scheduler"] == address
    assert results(tmp_path / "remote") == local


def test_a_dask_worker_that_dies_is_charged_to_its_spec(local_dask_clusters):
    """A local Dask cluster of two workers (local_dask_clusters: after the executors'
    comparison, on the same forkserver), its scheduler allowing no retry of a spec whose
    worker died: that spec's row says so, the others are solved."""
    outcome = local_dask_clusters["worker-died"]
    rows = {row["id"]: row for row in outcome.document["rows"]}
    assert rows["axis-crash"]["status"] == "worker_died"
    assert [rows[f"axis-00{i}"]["status"] for i in range(4)] == ["optimal"] * 4


def _serve_dask(send, address: str | None) -> None:
    """Until killed: a Dask scheduler on a free TCP port of 127.0.0.1, its address sent by
    ``send``, when ``address`` is None; else a single-threaded Dask worker of the
    scheduler at ``address``. Dask's log lines go nowhere."""
    import asyncio

    from distributed import Scheduler, Worker

    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 2)
    os.close(devnull)

    async def serve() -> None:
        if address is None:
            async with Scheduler(host="127.0.0.1", port=0, dashboard=False,
                                 dashboard_address=":0") as scheduler:
                send.send(scheduler.address)
                await scheduler.finished()
        else:
            async with Worker(address, nthreads=1) as worker:
                await worker.finished()

    asyncio.run(serve())


@contextlib.contextmanager
def dask_scheduler(workers: int):
    """A Dask scheduler and ``workers`` single-threaded workers, each a process of its own
    (so a test can kill the scheduler); yields (address, scheduler process).

    Each is a child forked from this process (spawned if it runs other threads, as
    in_a_fork's), not a ``python -m distributed.cli.dask_scheduler`` or ``dask_worker``:
    the batch under test is the process of its own here; a worker forked from this
    process has the tuner loaded (≈ 2 s of CPU less than a fresh one's first spec)."""
    from feedtune.batch.local import start_method

    context = multiprocessing.get_context(start_method())
    receive, send = context.Pipe(duplex=False)
    scheduler = context.Process(target=_serve_dask, args=(send, None), daemon=True)
    scheduler.start()
    send.close()
    processes = [scheduler]
    try:
        if not receive.poll(120):
            raise RuntimeError("the Dask scheduler did not start")
        address = receive.recv()
        for _ in range(workers):
            processes.append(context.Process(target=_serve_dask, args=(None, address),
                                             daemon=True))
            processes[-1].start()
        yield address, scheduler
    finally:
        receive.close()
        for process in processes:
            process.kill()
            process.join()


@pytest.mark.usefixtures("distributed_loaded")
def test_a_dask_scheduler_lost_mid_run_is_exit_two_keeping_what_finished(tmp_path):
    """The issue: exit 1, a traceback and `error` rows. Now: one line naming the
    scheduler, exit 2, the finished results in the summary, the rest `not_run` for a rerun."""
    specs, out = tmp_path / "specs", tmp_path / "out"
    write_specs(specs, 12)
    with dask_scheduler(workers=1) as (address, scheduler):
        process = start_cli("batch", str(specs), "--out", str(out), "--scheduler", address,
                            "-q", cwd=REPO, text=True)
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and len(list(out.glob("axis-*.json"))) < 3:
            time.sleep(0.02)
        scheduler.kill()
        _, err = process.communicate(timeout=120)
    assert process.returncode == 2, err
    (line,) = err.splitlines()
    assert line.startswith(f"error: lost the Dask scheduler at {address} mid-run"), line
    rows = summary(out)["rows"]
    finished = [r for r in rows if r["status"] != "not_run"]
    assert 3 <= len(finished) < 12, "the kill should land mid-run"
    assert all(r["ok"] and (out / r["result"]).is_file() for r in finished)
    assert len(list(out.glob("axis-*.json"))) == len(finished)
    assert all(r["reason"] == "not_run" for r in rows if r not in finished)


@pytest.mark.usefixtures("distributed_loaded")
@pytest.mark.parametrize("case", ["no-workers", "no-scheduler"])
def test_no_dask_workers_or_scheduler_is_exit_two_after_the_worker_timeout(tmp_path, case):
    specs = tmp_path / "specs"
    write_specs(specs, 1)
    # no-scheduler: nothing to start; the discard port, where nothing listens
    with (dask_scheduler(workers=0) if case == "no-workers"
          else contextlib.nullcontext(("tcp://127.0.0.1:9", None))) as (address, _):
        started = time.monotonic()
        proc = run_forked("batch", str(specs), "--out", str(tmp_path / "out"), "--scheduler",
                          address, "--worker-timeout", "2", cwd=REPO, text=True, timeout=120)
    assert proc.returncode == 2, proc.stderr
    (line,) = proc.stderr.splitlines()
    expected = (f"error: no Dask workers connected to {address} within 2 s"
                if case == "no-workers" else f"error: cannot connect to the Dask scheduler at {address}: ")
    assert line.startswith(expected), line
    assert time.monotonic() - started < 60  # the timeout, not Dask's own waits


@pytest.mark.parametrize("case", list(WITHOUT_DASK))
def test_without_dask_installed_only_the_dask_executor_is_refused(fresh_without_dask, case):
    """Dask is the `dask` extra: without it (its import blocked in a fresh interpreter:
    fresh_without_dask) the local executor works and the Dask one says how to install it."""
    status, stderr, out = fresh_without_dask[case]
    if case == "local":
        assert status == 0, stderr
        assert rows_by_id(out)["axis-000"]["ok"]
        return
    assert status == 2, stderr
    (line,) = stderr.splitlines()
    assert line.startswith("error: ") and "pip install 'feedtune[dask]'" in line, line
    assert not out.exists()


def catches(pid: int, signum: int) -> bool:
    """Whether process ``pid`` has a handler for ``signum`` (Linux: SigCgt in /proc)."""
    with open(f"/proc/{pid}/status") as status:
        mask = next(line for line in status if line.startswith("SigCgt:")).split()[1]
    return bool(int(mask, 16) >> (signum - 1) & 1)


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="reads /proc (Linux)")
@pytest.mark.parametrize("delay", [0.1, 0.3, 0.6])
@pytest.mark.parametrize("stop", [signal.SIGINT, signal.SIGTERM], ids=["ctrl-c", "sigterm"])
def test_a_signal_early_in_the_batch_is_exit_130_without_a_traceback(tmp_path, stop, delay):
    """The issue: in the first ~0.6 s SIGINT gave "Aborted!" (exit 1) or a traceback, and
    SIGTERM exit 143. At any moment it is 130, one clear line, and any summary whole.

    ``delay`` counts from feedtune's first handlers (:func:`feedtune.interrupts.hold`, seen
    in /proc as SIGTERM caught: the interpreter itself catches only SIGINT), not from the
    fork or the interpreter's own SIGINT handler: what comes before ``hold`` is Python's
    start and ``import feedtune``, which took over 0.1 s at load 5 (where a Ctrl-C is
    Python's KeyboardInterrupt, as for any Python program)."""
    specs, out = tmp_path / "specs", tmp_path / "out"
    write_specs(specs, 3)
    process = subprocess.Popen([sys.executable, "-m", "feedtune", "batch", str(specs),
                                "--out", str(out), "-j", "1"], cwd=REPO,
                               stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 30
    while not catches(process.pid, signal.SIGTERM) and time.monotonic() < deadline:
        time.sleep(0.001)
    time.sleep(delay)
    process.send_signal(stop)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 130, err
    assert "Traceback" not in err and "Aborted" not in err
    assert err.splitlines()[-1] in (  # while the command line loads / once batch runs
        "feedtune: interrupted while starting; nothing was done",
        "interrupted: the results written so far are kept; rerun the same command to finish")
    if (out / "summary.json").exists():
        assert len(summary(out)["rows"]) == 3


def _raise_keyboard_interrupt(signum, frame):
    raise KeyboardInterrupt


@contextlib.contextmanager
def batch_signal_handlers():
    """SIGINT and SIGTERM raise KeyboardInterrupt meanwhile, as once ``feedtune batch``
    runs (its ``_Stop``), and are put back afterwards."""
    previous = {signum: signal.signal(signum, _raise_keyboard_interrupt)
                for signum in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)


def test_a_signal_as_a_worker_starts_leaves_no_worker_behind(tmp_path, monkeypatch):
    """The flaky ``[sigterm-0.6]`` case above, made deterministic: the SIGTERM reaches the
    batch right after a worker process has started. It raised its KeyboardInterrupt before
    the executor had listed that worker, so the batch ended without stopping it, and at
    exit multiprocessing sent it SIGTERM, which the worker, still starting with the batch's
    handlers, printed as a traceback. Now the worker is stopped with the batch."""
    started = multiprocessing.process.BaseProcess.start

    def start_then_sigterm(process):
        started(process)
        signal.raise_signal(signal.SIGTERM)

    write_specs(tmp_path / "specs", 2)
    monkeypatch.setattr(multiprocessing.process.BaseProcess, "start", start_then_sigterm)
    try:
        with batch_signal_handlers():
            outcome = run_batch([str(tmp_path / "specs")], tmp_path / "out",
                                LocalExecutor(1, start="fork"))
        assert outcome.interrupted
        assert [p.name for p in multiprocessing.active_children()] == []
    finally:
        for process in multiprocessing.active_children():  # left behind: not for the next test
            process.kill()
            process.join()


@pytest.mark.parametrize("stop", [signal.SIGINT, signal.SIGTERM], ids=["ctrl-c", "sigterm"])
def test_a_signal_reaching_a_worker_as_it_starts_prints_no_traceback(tmp_path, capfd, stop):
    """A Ctrl-C in a terminal reaches every process of its group, and CI's SIGTERM may
    too: a worker starting (forked with the batch's handlers, which raise
    KeyboardInterrupt) printed multiprocessing's traceback of its start. Now it ignores
    Ctrl-C, and SIGTERM ends it as in a spawned worker; the batch completes."""
    write_specs(tmp_path / "specs", 2)
    anchor = threading.Event()  # the hook is registered while this object lives
    multiprocessing.util.register_after_fork(anchor, batch_jobs.signal_once(tmp_path / "once",
                                                                            stop))
    try:
        with batch_signal_handlers():
            outcome = run_batch([str(tmp_path / "specs")], tmp_path / "out",
                                LocalExecutor(1, start="fork"))
    finally:
        del anchor
    assert (tmp_path / "once").exists()  # the signal was sent
    err = capfd.readouterr().err
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err
    assert [row["status"] for row in outcome.document["rows"]] == ["optimal"] * 2


#: a batch SIGKILLed right after it started its worker, which pauses as it starts (its pid
#: written to argv[1]), so that the batch is gone before the worker's own code runs
KILLED_AS_A_WORKER_STARTS = """
import multiprocessing.process, multiprocessing.util, os, signal, sys, threading, time
import feedtune.batch.job
from feedtune.batch.local import LocalExecutor

feedtune.batch.job.warm_up = lambda: None  # nothing to load: the worker's start is tested


def pause(_anchor):
    with open(sys.argv[1] + ".part", "w") as out:  # whole or absent: the test reads it as
        out.write(str(os.getpid()))                # soon as this process's batch is dead
    os.replace(sys.argv[1] + ".part", sys.argv[1])
    time.sleep(1.0)


anchor = threading.Event()
multiprocessing.util.register_after_fork(anchor, pause)
started = multiprocessing.process.BaseProcess.start


def start_then_die(process):
    started(process)
    os.kill(os.getpid(), signal.SIGKILL)


multiprocessing.process.BaseProcess.start = start_then_die
LocalExecutor(1, start="fork").run([(0, b"{}", None)], lambda index, outcome: None)
"""


def running(pid: int) -> bool:
    """Whether process ``pid`` exists and is not a zombie (Linux: /proc)."""
    try:
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().rpartition(")")[2].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads /proc (Linux)")
def test_a_worker_whose_batch_died_as_it_started_does_not_wait_forever(tmp_path):
    """A worker asks the kernel to kill it when its batch dies; a batch killed before the
    worker had asked left it waiting for work forever (the worker holds the batch's end
    of their connection too, so it never reads an end of file)."""
    with open(tmp_path / "stderr", "w") as stderr:  # not a pipe: the worker would hold it
        done = subprocess.run([sys.executable, "-c", KILLED_AS_A_WORKER_STARTS,
                               str(tmp_path / "worker")], stdout=subprocess.DEVNULL,
                              stderr=stderr, timeout=120, cwd=REPO)
    assert done.returncode == -signal.SIGKILL, (tmp_path / "stderr").read_text()
    # the batch died right after forking: under load its worker writes its pid only later
    # (an empty file was read at load 25 when the worker wrote it in place)
    deadline = time.monotonic() + 30
    while not (tmp_path / "worker").exists() and time.monotonic() < deadline:
        time.sleep(0.05)
    pid = int((tmp_path / "worker").read_text())
    try:
        deadline = time.monotonic() + 30
        while running(pid) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not running(pid), "the orphaned worker is still waiting"
    finally:
        if running(pid):
            os.kill(pid, signal.SIGKILL)


def test_a_ctrl_c_while_a_result_is_written_waits_until_its_row_says_so(tmp_path, monkeypatch):
    """A Ctrl-C landing inside one spec's bookkeeping (here: as its result is written) is
    held until the file and its summary row are both done, then stops the batch."""
    import feedtune.batch.runner as runner
    from feedtune.batch.job import Outcome

    write_atomic = runner.write_atomic

    def interrupted_write(path: Path, data: bytes) -> None:
        if path.name != "summary.json":
            # to this thread, handled before raise_signal returns: os.kill(getpid()) may go
            # to another of the test worker's threads, and under load reached the handler
            # only after the batch had gone on (the test failed at load 10)
            signal.raise_signal(signal.SIGINT)
        write_atomic(path, data)

    class OneSpec:
        def run(self, tasks, on_outcome):
            index = tasks[0][0]
            on_outcome(index, Outcome("optimal", "fine", spec_sha256="0" * 64, result=b"{}\n",
                                      row={"status": "optimal", "success": True,
                                           "constraints_satisfied": True, "objective": 1.0}))
            raise AssertionError("the Ctrl-C should have stopped the batch by now")

    write_specs(tmp_path / "specs", 2)
    monkeypatch.setattr(runner, "write_atomic", interrupted_write)
    # Python's own Ctrl-C handler, which the batch re-raises to: a suite started in the
    # background of a shell (`pytest &`) inherits SIGINT ignored, and there the re-raised
    # signal is rightly ignored (this test failed in every such run on 2026-11-27)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        outcome = run_batch([str(tmp_path / "specs")], tmp_path / "out", OneSpec())
    finally:
        signal.signal(signal.SIGINT, previous)
    assert outcome.interrupted
    row = outcome.document["rows"][0]
    assert row["status"] == "optimal" and row["result"] == "axis-000.json" and row["ok"]
    assert (tmp_path / "out" / "axis-000.json").read_bytes() == b"{}\n"
    assert outcome.document["rows"][1]["status"] == "not_run"


def test_run_batch_works_from_a_thread_other_than_the_main_one(tmp_path):
    """Holding signals back is the main thread's business; a library caller's thread
    cannot touch them, and need not."""
    from feedtune.batch.job import Outcome

    class Instant:
        def run(self, tasks, on_outcome):
            for index, _, _ in tasks:
                on_outcome(index, Outcome("error", "not solved here"))

    write_specs(tmp_path / "specs", 2)
    outcomes = []
    thread = threading.Thread(target=lambda: outcomes.append(
        run_batch([str(tmp_path / "specs")], tmp_path / "out", Instant())))
    thread.start()
    thread.join(timeout=60)
    (outcome,) = outcomes
    assert [row["reason"] for row in outcome.document["rows"]] == ["error", "error"]


def test_the_batch_command_in_process_leaves_the_signal_handlers_as_it_found_them(tmp_path):
    from click.testing import CliRunner

    from feedtune.cli import main

    before = signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)
    result = CliRunner().invoke(main, ["batch", str(tmp_path / "nope.json"), "--out",
                                       str(tmp_path / "out")])
    assert result.exit_code == 2 and "nope.json: no such file" in result.output
    assert (signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)) == before


def test_the_dask_tests_leave_no_thread_in_this_process(threads_before):
    """Last in the file: the Dask clients above ran in forked children (in_a_fork). One run
    here left distributed's offload thread in this process for good, and every later batch
    here spawned its workers instead of forking them (:func:`start_method`)."""
    assert {thread.name for thread in threading.enumerate()} <= threads_before
