"""The validator's linear model (``feedtune/validate/linear.py``): its frequency responses
and its time responses, new against a git revision's modules, side by side in one process
(issue 15).

* Frequency: the model's construction, M_peak and phase margin of the user-defined drive
  over a grid of dead times and inertias, as ``tests/reference/test_robust_plants.py``
  re-measures a robust design on 41 × 41 plants (≈ 1 700 models). Each plant is built and
  measured by the new module and by the baseline's in turn; the largest relative
  difference of each value and how many are the same bits are printed.
* Time: the ISE after a step and a ramp of the long-lived PID + notch design of
  ``tests/cli/test_pid_notch_example.py`` (a mode at 1717 rad/s decaying at 0.13 1/s: 31
  million time steps), new against the baseline's ``linear.py`` and ``continuous.py``
  propagation, with the peak of numpy's traced memory.

    .venv/bin/python benchmarks/validator_linear_response.py [--baseline main] [--points 21]
        [--no-time]
"""

from __future__ import annotations

import argparse
import copy
import json
import sys
import time
import tracemalloc
from pathlib import Path

from baseline import baseline_module

REPO = Path(__file__).resolve().parents[1]
MODULE = "feedtune/validate/linear.py"
#: tests/cli/test_pid_notch_example.py's LONG_LIVED design of examples/user-defined-pid-notch.json
LONG_LIVED = {"position_controller.kp": 1.13090766e5, "position_controller.ti": 0.93769363,
              "position_controller.td": 6.41815256e-3, "position_controller.n": 10.0,
              "notch.frequency": 1677.00924, "notch.width": 0.155870208,
              "notch.depth": 0.213148571}


def _as(model, cls):
    """``model`` (a new LinearModel) measured by class ``cls``, nothing cached shared."""
    other = copy.copy(model)
    other.__dict__ = dict(model.__dict__)
    other.__class__ = cls
    return other


def frequency(old, points: int) -> None:
    import numpy as np

    from feedtune.schema.uncertainty import with_numbers
    from feedtune.validate.linear import LinearModel
    from feedtune.validate.models import model_for

    spec = json.loads((REPO / "examples" / "user-defined-drive.json").read_text())
    tuned = {name: t.get("initial", t.get("value")) for name, t in spec["tunables"].items()}
    grid = [{"dead_time": theta, "model.denominator.2": a}
            for theta in np.linspace(1e-4, 4e-4, points) for a in np.linspace(4.2, 7.8, points)]
    models = [model_for(with_numbers(spec["plant"], p), tuned) for p in grid]
    assert all(isinstance(m, LinearModel) for m in models)
    whats = ("build", "m_peak", "phase_margin")
    cpu = {(label, what): 0.0 for label in ("new", "old") for what in whats}
    worst = {"m_peak": 0.0, "phase_margin": 0.0}
    same = {"m_peak": 0, "phase_margin": 0}
    for point in grid:
        values = {}
        plant = with_numbers(spec["plant"], point)
        for label in ("old", "new"):
            start = time.process_time()
            m = (LinearModel if label == "new" else old.LinearModel)(plant, tuned)
            cpu[label, "build"] += time.process_time() - start
            for what in ("m_peak", "phase_margin"):
                start = time.process_time()
                values[label, what] = getattr(m, what)()
                cpu[label, what] += time.process_time() - start
        for what in worst:
            new, base = values["new", what], values["old", what]
            worst[what] = max(worst[what], abs(new - base) / abs(base))
            same[what] += new == base
    print(f"{len(models)} models of the user-defined drive (CPU s, new against old):")
    for what in whats:
        new, base = cpu["new", what], cpu["old", what]
        print(f"  {what:13s} new {new:6.2f}  old {base:6.2f}  new/old {new / base:.3f}"
              + (f"  largest relative difference {worst[what]:.1e}, {same[what]} of "
                 f"{len(grid)} the same bits" if what in worst else ""))
    new, base = (sum(cpu[label, what] for what in whats) for label in ("new", "old"))
    print(f"  {'all':13s} new {new:6.2f}  old {base:6.2f}  new/old {new / base:.3f}")


def time_domain(old, revision: str) -> None:
    from feedtune.validate.integrals import error_integrals
    from feedtune.validate.linear import LinearModel

    old_continuous = baseline_module(revision, "feedtune/validate/continuous.py",
                                     "baseline_validate_continuous")
    plant = json.loads((REPO / "examples" / "user-defined-pid-notch.json").read_text())["plant"]
    print("the long-lived PID + notch design, ISE after a step and a ramp:")
    values = {}
    for label in ("old", "new"):
        model = LinearModel(plant, LONG_LIVED)
        if label == "old":
            model = _as(model, old.LinearModel)
            # the baseline's propagation: every state kept, then C x per step
            old.__dict__["_propagate"] = old_continuous._propagate
        tracemalloc.start()
        start = time.process_time()
        values[label] = [error_integrals(*model._error(kind)[:2])["ise"]
                         for kind in ("step", "ramp")]
        cpu = time.process_time() - start
        peak = tracemalloc.get_traced_memory()[1] / 2**20
        tracemalloc.stop()
        print(f"  {label}: {cpu:6.2f} s of CPU, traced peak {peak:7.0f} MiB, "
              f"ISE {values[label][0]:.12g}, {values[label][1]:.12g}, "
              f"{model._grid_steps().size} steps")
    for new, base in zip(values["new"], values["old"]):
        print(f"  relative difference {abs(new - base) / abs(base):.1e}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", default="main", help="git revision of the old modules")
    parser.add_argument("--points", type=int, default=21, help="grid points per parameter")
    parser.add_argument("--no-time", action="store_true",
                        help="skip the time responses (the baseline's holds ≈ 6 GB)")
    args = parser.parse_args()
    from feedtune.__main__ import pin_blas_threads

    pin_blas_threads()
    old = baseline_module(args.baseline, MODULE, "baseline_validate_linear")
    frequency(old, args.points)
    if not args.no_time:
        time_domain(old, args.baseline)


if __name__ == "__main__":
    sys.exit(main())
