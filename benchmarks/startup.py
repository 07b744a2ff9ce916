"""Start-up time of the command line: `feedtune --help`, `feedtune validate`, `feedtune tune`,
`feedtune batch`.

Each command runs REPEAT times, interleaved with its baseline (a bare interpreter,
`python -c pass`), in fresh processes from this one (wall time and the process's CPU time,
user + system), after one unmeasured run that warms the
disk cache and writes feedtune's bytecode (as any first run after an install does; the
processes run without PYTHONDONTWRITEBYTECODE, which a user does not set); the median wall
time of each, the command's time over the baseline's, the median CPU times, and issue 15's
target are printed.
The three heaviest imports of `feedtune.schema.spec` (what `validate` loads) are listed from
`python -X importtime`, so a change shows where the time went.

With ``--baseline DIR`` (another tree of feedtune, e.g. ``git archive main | tar -x -C DIR``)
each command also runs from DIR (its ``feedtune`` package: ``python -m`` puts the working
directory first on the path) interleaved with this tree's, on the same example files, and
the baseline's medians and this tree's CPU over the baseline's are printed too.

With ``--all-examples`` the cases are ``--help`` and ``validate`` of every bundled example
(``examples/*.json``, issue 15's target holds for each), without ``tune``.

With ``--instructions`` each command but ``tune`` also runs once under valgrind's callgrind
(``PYTHONHASHSEED=0``), in this tree and the baseline's, and the instructions it executed
are printed: a count that the machine's load does not change (CPU times on 2 shared cores
vary by ±15 % between runs), ≈ 10 s of CPU a run.

With ``--floor`` (and ``--instructions``) it also counts what feedtune's code cannot go
below: a bare interpreter, pydantic imported and one one-field model built, and that with
click imported too (the collector off and no teardown, as ``validate`` runs).

Run: ``.venv/bin/python benchmarks/startup.py [--repeat N] [--baseline DIR] [--instructions]
[--all-examples] [--floor]``
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
EXAMPLE = str(REPO / "examples" / "koren-1979-sampled-data.json")
#: the sampled user-defined drive: its check builds no loop matrices since issue 16's stop
SAMPLED_USER = str(REPO / "examples" / "user-defined-sampled-drive.json")
#: the environment of every measured process: bytecode cached as after a first run
ENV = {name: value for name, value in os.environ.items() if name != "PYTHONDONTWRITEBYTECODE"}
#: the ``batch`` case's result directory, removed before each run (else the result is kept)
BATCH_OUT = Path(tempfile.gettempdir()) / "feedtune-startup-batch"
CASES = {  # name: (arguments after `python -m feedtune`, issue 15's target [s] or None)
    "--help": (["--help"], 0.3),
    "validate": (["validate", EXAMPLE], 0.3),
    "validate (sampled user)": (["validate", SAMPLED_USER], 0.3),
    "tune (Koren's example)": (["tune", EXAMPLE, "-q"], None),
    # the batch's process loads and warms the tuner, then forks one worker for the spec
    "batch (Koren's example, 1 worker)": (["batch", EXAMPLE, "--out", str(BATCH_OUT), "-q",
                                           "-j", "1"], None),
}
#: ``--floor``: the dependencies alone, as ``feedtune validate`` loads them (collector off,
#: no interpreter teardown)
_PYDANTIC_MODEL = ("import gc, os; gc.disable(); from pydantic import BaseModel; "
                   "M = type('M', (BaseModel,), {'__annotations__': {'x': float}}); ")
FLOOR = {"a bare interpreter": "pass",
         "pydantic, one model": _PYDANTIC_MODEL + "os._exit(0)",
         "pydantic, one model, click": _PYDANTIC_MODEL + "import click; os._exit(0)"}
#: ``--all-examples``: ``--help`` and ``validate`` of every bundled example
ALL_EXAMPLES = {"--help": CASES["--help"],
                **{f"validate {path.stem}": (["validate", str(path)], 0.3)
                   for path in sorted((REPO / "examples").glob("*.json"))}}


def wall(command: list[str], cwd: Path = REPO) -> tuple[float, float]:
    """(wall, CPU) time [s] of one run of ``command`` in ``cwd``, output discarded; CPU is the
    child's user + system time, which a loaded machine inflates far less than the wall time."""
    shutil.rmtree(BATCH_OUT, ignore_errors=True)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    subprocess.run(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True,
                   cwd=cwd, env=ENV)
    elapsed = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return elapsed, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def instructions(command: list[str], cwd: Path = REPO) -> int:
    """Instructions one run of ``command`` in ``cwd`` executes (valgrind's callgrind), with
    pydantic's plugins off as the ``feedtune`` command has them."""
    proc = subprocess.run(["valgrind", "--tool=callgrind", "--callgrind-out-file=/dev/null",
                           *command], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                          text=True, check=True, cwd=cwd,
                          env={"PYDANTIC_DISABLE_PLUGINS": "__all__", **ENV, "PYTHONHASHSEED": "0"})
    return int(re.search(r"refs:\s+([\d,]+)", proc.stderr).group(1).replace(",", ""))


def heaviest_imports(module: str, count: int = 3) -> list[tuple[float, str]]:
    """(cumulative seconds, name) of the ``count`` slowest imports below ``module``."""
    proc = subprocess.run([sys.executable, "-X", "importtime", "-c", f"import {module}"],
                          capture_output=True, text=True, check=True, cwd=REPO, env=ENV)
    rows = []
    for line in proc.stderr.splitlines():
        parts = line.removeprefix("import time:").split("|")
        if len(parts) == 3 and parts[1].strip().isdigit():
            rows.append((int(parts[1]) / 1e6, parts[2].rstrip()))
    top = max(rows)[0]
    children = [(t, name) for t, name in rows if name.strip() != module]
    return [(top, module)] + sorted(children, reverse=True)[:count]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7, help="runs per case [count]")
    parser.add_argument("--baseline", type=Path, help="another feedtune tree to compare with")
    parser.add_argument("--instructions", action="store_true",
                        help="also count each command's instructions (valgrind)")
    parser.add_argument("--all-examples", action="store_true",
                        help="validate every bundled example (and --help), not tune")
    parser.add_argument("--floor", action="store_true",
                        help="with --instructions: also count pydantic's and click's floor")
    args = parser.parse_args()
    cases = ALL_EXAMPLES if args.all_examples else CASES
    width = max(len(name) for name in cases)
    if args.instructions and shutil.which("valgrind") is None:
        parser.error("--instructions needs valgrind")
    baseline_command = [sys.executable, "-c", "pass"]
    print(f"load average {os.getloadavg()[0]:.1f}")
    print(f"{'case':<{width}} {'median [s]':>10} {'baseline [s]':>12} {'ratio':>6} {'CPU [s]':>8} "
          f"{'base CPU':>8} {'target [s]':>10}"
          + (f" {'tree [s]':>9} {'tree CPU':>8} {'CPU/tree':>8}" if args.baseline else ""))
    for name, (arguments, target) in cases.items():
        times, base, tree = [], [], []
        command = [sys.executable, "-m", "feedtune", *arguments]
        wall(command)  # warm-up, not measured
        if args.baseline:
            wall(command, args.baseline)
        for _ in range(args.repeat):  # interleaved: load from elsewhere hits both alike
            base.append(wall(baseline_command))
            times.append(wall(command))
            if args.baseline:
                tree.append(wall(command, args.baseline))
        t, b = (statistics.median(w for w, _ in runs) for runs in (times, base))
        cpu, base_cpu = (statistics.median(c for _, c in runs) for runs in (times, base))
        line = (f"{name:<{width}} {t:>10.3f} {b:>12.3f} {t / b:>6.1f} {cpu:>8.3f} {base_cpu:>8.3f} "
                f"{'—' if target is None else f'{target:.1f}':>10}")
        if args.baseline:
            tree_wall, tree_cpu = (statistics.median(x[i] for x in tree) for i in (0, 1))
            line += f" {tree_wall:>9.3f} {tree_cpu:>8.3f} {cpu / tree_cpu:>8.2f}"
        print(line)
    if args.instructions:
        print(f"\n{'case':<{width}} {'instructions':>14}"
              + (f" {'tree':>14} {'ratio':>6}" if args.baseline else ""))
        for name, (arguments, target) in cases.items():
            if target is None:
                continue  # a tuning: minutes under valgrind
            command = [sys.executable, "-m", "feedtune", *arguments]
            count = instructions(command)
            line = f"{name:<{width}} {count:>14,}"
            if args.baseline:
                tree = instructions(command, args.baseline)
                line += f" {tree:>14,} {count / tree:>6.3f}"
            print(line)
    if args.instructions and args.floor:
        print("\nthe floor (the dependencies alone, PYDANTIC_DISABLE_PLUGINS=__all__):")
        for name, code in FLOOR.items():
            count = instructions([sys.executable, "-c", code])
            print(f"  {name:<{width - 2}} {count:>14,}")
    print("\nslowest imports under feedtune.schema.spec (cumulative, one run):")
    for seconds, module in heaviest_imports("feedtune.schema.spec"):
        print(f"  {seconds:6.3f} s  {module.strip()}")


if __name__ == "__main__":
    main()
