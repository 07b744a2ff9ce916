"""A spec from a pull request is untrusted input: it may not name a file, a library or a
command that feedtune then touches (README, "Trust model"). Each test plants the harm a
spec could do before the allow-list (a file emptied, a file echoed, a library loaded, a
symlink followed, a log line forged) and shows it is gone, through the real command line:
``validate``, ``tune`` and ``batch`` alike."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pytest

from feedtune_cli import run_cli

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "examples" / "koren-1979-sampled-data.json"
SECRET = "correct-horse-battery-staple"


def run(*args: str, stdin: bytes = b"", cwd: Path = REPO) -> subprocess.CompletedProcess:
    """``feedtune ARGS`` through the real entry point in this process (bytes out;
    tests/feedtune_cli.py), never raising on exit status. ``batch`` too: what these tests
    check is the files and lines a batch writes, not its process; its workers are forked
    from this one as from ``python -m feedtune batch`` (≈ 1.8 s of CPU saved a batch:
    benchmarks/README.md, "Branch h-tcli")."""
    return run_cli(*args, stdin=stdin, cwd=cwd)


def text(proc) -> str:
    return (proc.stdout + proc.stderr).decode("utf-8", "replace")


def spec(**solver) -> dict:
    doc = json.loads(EXAMPLE.read_bytes())
    doc["solver"] = {"multistart": 1, **solver}
    return doc


def write(path: Path, doc: dict) -> Path:
    path.write_text(json.dumps(doc))
    return path


def batch_row(tmp_path: Path, spec_path: Path,
              quiet: bool = True) -> tuple[subprocess.CompletedProcess, dict]:
    out = tmp_path / "batch-out"
    proc = run("batch", str(spec_path), "--out", str(out), *(["-q"] if quiet else []))
    rows = json.loads((out / "summary.json").read_bytes())["rows"]
    assert len(rows) == 1
    return proc, rows[0]


def assert_refused(proc, pointer: str) -> None:
    assert proc.returncode == 2, text(proc)
    assert f": {pointer}: " in proc.stderr.decode(), text(proc)
    assert "Traceback" not in text(proc)


# -- files named by IPOPT options ------------------------------------------------------------

@pytest.mark.parametrize("command", ["validate", "tune", "batch"])
def test_output_file_cannot_touch_a_file(tmp_path, command):
    """IPOPT opened ``output_file`` for writing: an existing file was emptied, even by
    ``validate``. Now the option is refused and the file keeps its bytes."""
    victim = tmp_path / "precious.txt"
    victim.write_text(SECRET)
    path = write(tmp_path / "spec.json", spec(ipopt_options={"output_file": str(victim)}))
    if command == "batch":
        proc, row = batch_row(tmp_path, path)
        assert proc.returncode == 1, text(proc)
        assert row["status"] == "invalid"
        assert [e["pointer"] for e in row["errors"]] == ["/solver/ipopt_options/output_file"]
    else:
        proc = run(command, str(path))
        assert_refused(proc, "/solver/ipopt_options/output_file")
        assert "allowed: " in proc.stderr.decode() and "mu_strategy" in proc.stderr.decode()
    assert victim.read_text() == SECRET


def test_option_file_name_echoes_nothing_of_the_file(tmp_path):
    """IPOPT read ``option_file_name`` and put its first word into the error message."""
    secret = tmp_path / "secret.txt"
    secret.write_text(f"{SECRET} 1\n")
    path = write(tmp_path / "spec.json", spec(ipopt_options={"option_file_name": str(secret)}))
    for command in ("validate", "tune"):
        proc = run(command, str(path))
        assert_refused(proc, "/solver/ipopt_options/option_file_name")
        assert SECRET not in text(proc)


def test_an_ipopt_opt_file_in_the_working_directory_is_not_read(tmp_path):
    """IPOPT reads ``./ipopt.opt`` unless told otherwise; a checkout may hold one (and it
    could name a library). feedtune tells IPOPT to read no options file."""
    marker = tmp_path / "ipopt-log.txt"
    (tmp_path / "ipopt.opt").write_text(f"output_file {marker}\nfile_print_level 5\n")
    path = write(tmp_path / "spec.json", spec())
    proc = run("tune", str(path), "-o", str(tmp_path / "result.json"), cwd=tmp_path)
    assert proc.returncode == 0, text(proc)
    assert not marker.exists()


# -- libraries named by IPOPT options --------------------------------------------------------

LIBRARY = r"""
#include <stdio.h>
__attribute__((constructor)) static void planted(void) {
    FILE *f = fopen(MARKER, "w");
    if (f) { fputs("loaded", f); fclose(f); }
}
"""


@pytest.fixture
def planted_library(tmp_path) -> tuple[Path, Path]:
    """A shared library whose constructor writes a marker file when it is loaded."""
    if shutil.which("gcc") is None:
        pytest.skip("gcc is not installed: cannot build the library that proves nothing is loaded")
    marker = tmp_path / "library-was-loaded"
    source = tmp_path / "planted.c"
    source.write_text(LIBRARY)
    library = tmp_path / "libplanted.so"
    subprocess.run(["gcc", "-shared", "-fPIC", f'-DMARKER="{marker}"', "-o", str(library),
                    str(source)], check=True, capture_output=True)
    return library, marker


def test_the_planted_library_proves_a_load(planted_library):
    """The proof works: loading the library does write the marker."""
    import ctypes

    library, marker = planted_library
    ctypes.CDLL(str(library))
    assert marker.read_text() == "loaded"


@pytest.mark.parametrize("command", ["validate", "tune", "batch"])
@pytest.mark.parametrize("options, pointer", [
    ({"linear_solver": "ma27", "hsllib": "LIBRARY"}, "/solver/ipopt_options/hsllib"),
    ({"linear_solver": "pardiso", "pardisolib": "LIBRARY"}, "/solver/ipopt_options/pardisolib"),
])
def test_a_spec_cannot_load_a_library(tmp_path, planted_library, command, options, pointer):
    library, marker = planted_library
    options = {k: str(library) if v == "LIBRARY" else v for k, v in options.items()}
    path = write(tmp_path / "spec.json", spec(ipopt_options=options))
    if command == "batch":
        proc, row = batch_row(tmp_path, path)
        assert proc.returncode == 1, text(proc)
        assert row["status"] == "invalid"
        pointers = [e["pointer"] for e in row["errors"]]
    else:
        proc = run(command, str(path))
        assert proc.returncode == 2, text(proc)
        pointers = [line.split(": ")[2] for line in proc.stderr.decode().splitlines()
                    if line.startswith("error: ")]
    assert sorted(pointers) == sorted([pointer, "/solver/ipopt_options/linear_solver"])
    assert not marker.exists()


# -- solver failures ------------------------------------------------------------------------

def test_an_option_ipopt_rejects_at_solve_time_gives_a_result_and_a_message(tmp_path):
    """Allowed options can still conflict (MUMPS' pivot tolerance above its maximum): IPOPT
    says Invalid_Option when it starts; that is a result with status error, not a crash."""
    path = write(tmp_path / "spec.json",
                 spec(ipopt_options={"mumps_pivtol": 0.5, "mumps_pivtolmax": 0.1}))
    proc = run("tune", str(path), "-o", str(tmp_path / "result.json"))
    assert proc.returncode == 1, text(proc)
    assert "Traceback" not in text(proc)
    result = json.loads((tmp_path / "result.json").read_bytes())
    assert result["success"] is False and result["status"] == "error"
    assert "Invalid_Option" in result["message"]


# -- names, pointers and log lines ----------------------------------------------------------

def test_a_key_cannot_forge_a_log_line(tmp_path):
    """A key is echoed in its error's pointer; a newline in it would start a line of its
    own on stderr, which CI reads for workflow commands (``::error::``)."""
    doc = spec()
    doc["tunables"]["x\n::error::forged\x1b[2J"] = {}
    path = write(tmp_path / "spec.json", doc)
    proc = run("validate", str(path))
    assert proc.returncode == 2, text(proc)
    lines = proc.stderr.decode().splitlines()
    assert not any(line.startswith("::") for line in lines)
    assert "\x1b" not in proc.stderr.decode()
    assert any("/tunables/x\\n::error::forged\\u001b[2J: unknown tunable" in line for line in lines)


@pytest.mark.parametrize("name", ["axis\n::error::forged", "axis\x1b[31m", "axis\x00", "axis\x85"])
def test_a_name_holds_printable_characters_only(tmp_path, name):
    doc = spec()
    doc["name"] = name
    proc = run("validate", "-", stdin=json.dumps(doc).encode())
    assert_refused(proc, "/name")
    assert "control character" in proc.stderr.decode()


# -- symlinks in --out -----------------------------------------------------------------------

def test_a_symlink_planted_in_the_output_directory_is_replaced_not_followed(tmp_path):
    """A result is written to a temporary file and renamed over its name: a symlink of
    that name (the spec's result, the summary) is replaced, and the file it pointed to
    outside the directory is untouched."""
    outside = tmp_path / "outside.txt"
    outside.write_text(SECRET)
    out = tmp_path / "out"
    out.mkdir()
    doc = spec()
    (out / f"{doc['name']}.json").symlink_to(outside)
    (out / "summary.json").symlink_to(outside)
    path = write(tmp_path / "spec.json", doc)
    proc = run("batch", str(path), "--out", str(out), "-q")
    assert proc.returncode == 0, text(proc)
    assert outside.read_text() == SECRET
    for name in (f"{doc['name']}.json", "summary.json"):
        assert not (out / name).is_symlink()
    assert json.loads((out / f"{doc['name']}.json").read_bytes())["success"] is True


def test_a_symlinked_lock_file_is_not_followed(tmp_path):
    """The batch lock was opened through a planted symlink, creating the file it named
    anywhere the user may write; now the batch refuses the directory (exit 2)."""
    out = tmp_path / "out"
    out.mkdir()
    never = tmp_path / "never-created"
    (out / ".feedtune-batch.lock").symlink_to(never)
    proc = run("batch", str(write(tmp_path / "spec.json", spec())), "--out", str(out), "-q")
    assert proc.returncode == 2, text(proc)
    assert "symbolic link" in proc.stderr.decode() and "Traceback" not in text(proc)
    assert not never.exists()


# -- byte-order mark -------------------------------------------------------------------------

def test_a_utf8_bom_is_accepted_from_file_stdin_and_json_lines(tmp_path):
    data = b"\xef\xbb\xbf" + EXAMPLE.read_bytes()
    (tmp_path / "bom.json").write_bytes(data)
    assert run("validate", str(tmp_path / "bom.json")).returncode == 0
    proc = run("validate", "-", stdin=data)
    assert proc.returncode == 0, text(proc)
    lines = tmp_path / "fleet.jsonl"
    lines.write_bytes(b"\xef\xbb\xbf" + json.dumps(spec()).encode() + b"\n")
    proc, row = batch_row(tmp_path, lines)
    assert proc.returncode == 0, text(proc)
    assert row["status"] in ("optimal", "acceptable")


# -- work limits: validate refuses exactly what tune refuses ---------------------------------

def test_over_the_step_response_sample_limit_validate_and_tune_agree(tmp_path):
    """An IAE over a sampling-period box down to 0.1 µs needs millions of samples; tune
    refused it (at /tunables) after validate had passed it. Both now refuse it, at the
    term that sums the step response, with the same lines."""
    doc = spec()
    doc["objective"] = [{"metric": "iae"}]
    doc["tunables"]["sampling_period"] = {"min": 1e-7, "max": 0.02}
    path = write(tmp_path / "spec.json", doc)
    validate, tune = run("validate", str(path)), run("tune", str(path))
    assert_refused(validate, "/objective/0/metric")
    assert "limit 50000" in validate.stderr.decode()
    assert tune.returncode == 2 and tune.stderr == validate.stderr and tune.stdout == b""


@pytest.mark.parametrize("section, item, limit", [
    ("objective", {"metric": "radial_error", "radius": 0.008, "feed": 0.04}, 64),
    ("constraints", {"metric": "damping_ratio", "min": 0.5}, 64),
])
def test_terms_and_constraints_are_bounded(tmp_path, section, item, limit):
    doc = spec()
    doc[section] = [item] * limit
    assert run("validate", str(write(tmp_path / "ok.json", doc))).returncode == 0
    doc[section] = [item] * (limit + 1)
    proc = run("validate", str(write(tmp_path / "over.json", doc)))
    assert_refused(proc, f"/{section}")
    assert f"Array should have at most {limit} items, not {limit + 1}" in proc.stderr.decode()


def test_a_key_cannot_forge_a_log_line_in_the_batch_table(tmp_path):
    """The batch prints each failing spec's message in its table on stderr."""
    doc = spec()
    doc["tunables"]["x\n::error::forged"] = {}
    proc, row = batch_row(tmp_path, write(tmp_path / "spec.json", doc), quiet=False)
    assert proc.returncode == 1, text(proc)
    assert row["status"] == "invalid" and "x\\n::error::forged" in row["message"]
    assert "FAIL: /tunables/x\\n::error::forged: unknown tunable" in proc.stderr.decode()
    assert not any(line.startswith("::") for line in proc.stderr.decode().splitlines())
