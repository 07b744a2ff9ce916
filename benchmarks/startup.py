"""Start-up time of the command line: `feedtune --help`, `feedtune validate`, `feedtune tune`.

Each command runs REPEAT times, interleaved with its baseline (a bare interpreter,
`python -c pass`), in fresh processes from this one, after one unmeasured run that warms the
disk cache and writes feedtune's bytecode (as any first run after an install does; the
processes run without PYTHONDONTWRITEBYTECODE, which a user does not set); the median wall
time of each, the command's time over the baseline's, and issue 15's target are printed.
The three heaviest imports of `feedtune.spec` (what `validate` loads) are listed from
`python -X importtime`, so a change shows where the time went.

Run: ``.venv/bin/python benchmarks/startup.py [--repeat N]``
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
EXAMPLE = str(REPO / "examples" / "koren-1979-sampled-data.json")
#: the environment of every measured process: bytecode cached as after a first run
ENV = {name: value for name, value in os.environ.items() if name != "PYTHONDONTWRITEBYTECODE"}
CASES = {  # name: (arguments after `python -m feedtune`, issue 15's target [s] or None)
    "--help": (["--help"], 0.3),
    "validate": (["validate", EXAMPLE], 0.3),
    "tune (Koren's example)": (["tune", EXAMPLE, "-q"], None),
}


def wall(command: list[str]) -> float:
    """Wall time [s] of one run of ``command``, output discarded."""
    started = time.perf_counter()
    subprocess.run(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True,
                   cwd=REPO, env=ENV)
    return time.perf_counter() - started


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
    args = parser.parse_args()
    baseline_command = [sys.executable, "-c", "pass"]
    print(f"{'case':<24} {'median [s]':>10} {'baseline [s]':>12} {'ratio':>6} {'target [s]':>10}")
    for name, (arguments, target) in CASES.items():
        times, base = [], []
        wall([sys.executable, "-m", "feedtune", *arguments])  # warm-up, not measured
        for _ in range(args.repeat):  # interleaved: load from elsewhere hits both alike
            base.append(wall(baseline_command))
            times.append(wall([sys.executable, "-m", "feedtune", *arguments]))
        t, b = statistics.median(times), statistics.median(base)
        print(f"{name:<24} {t:>10.3f} {b:>12.3f} {t / b:>6.1f} "
              f"{'—' if target is None else f'{target:.1f}':>10}")
    print("\nslowest imports under feedtune.spec (cumulative, one run):")
    for seconds, module in heaviest_imports("feedtune.spec"):
        print(f"  {seconds:6.3f} s  {module.strip()}")


if __name__ == "__main__":
    main()
