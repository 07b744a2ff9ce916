"""The validator's error integrals (``feedtune/validate/integrals.py``), this checkout's
against a git revision's, side by side in one process (issue 15).

The long-lived PID + notch design of ``tests/cli/test_pid_notch_example.py`` (a mode at
1717 rad/s decaying at 0.13 1/s: 31 million time steps) reports the ISE after a step and
after a ramp, and the validator re-measures each (``continuous._integral``). Printed per
input: the CPU [s] of the baseline's ``error_integrals`` (which computes IAE, ISE and ITAE
whatever is asked) and of this checkout's asked for the ISE alone, and whether the ISE is
the same float. Then both on random grids: every integral, alone and all three, equal.

    .venv/bin/python benchmarks/validator_integrals.py [--baseline main]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
from baseline import baseline_module, short_revision

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from feedtune.validate.integrals import error_integrals  # noqa: E402
from feedtune.validate.linear import LinearModel  # noqa: E402

#: tests/cli/test_pid_notch_example.py's LONG_LIVED design of examples/user-defined-pid-notch.json
LONG_LIVED = {"position_controller.kp": 1.13090766e5, "position_controller.ti": 0.93769363,
              "position_controller.td": 6.41815256e-3, "position_controller.n": 10.0,
              "notch.frequency": 1677.00924, "notch.width": 0.155870208,
              "notch.depth": 0.213148571}
NAMES = ("iae", "ise", "itae")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", default="main")
    args = parser.parse_args()
    old = baseline_module(args.baseline, "feedtune/validate/integrals.py", "baseline_integrals")
    spec = json.loads((REPO / "examples" / "user-defined-pid-notch.json").read_text())
    model = LinearModel(spec["plant"], LONG_LIVED)
    print(f"baseline {args.baseline} ({short_revision(args.baseline)}); CPU s")
    for kind in ("step", "ramp"):
        t, e = model._error(kind)[:2]
        start = time.process_time()
        before = old.error_integrals(t, e)["ise"]
        middle = time.process_time()
        after = error_integrals(t, e, ("ise",))["ise"]
        end = time.process_time()
        print(f"ISE after a {kind}, {t.size} points: baseline {middle - start:.2f}, new "
              f"{end - middle:.2f} ({(end - middle) / (middle - start):.2f}); same float "
              f"{before == after}")
    rng = np.random.default_rng(1)
    same = True
    for _ in range(50):
        t, e = np.cumsum(rng.random(1000)), rng.standard_normal(1000)
        expected = old.error_integrals(t, e)
        same &= error_integrals(t, e) == expected
        same &= all(error_integrals(t, e, (n,)) == {n: expected[n]} for n in NAMES)
    print(f"50 random grids, each integral alone and all three: same floats {same}")


if __name__ == "__main__":
    main()
