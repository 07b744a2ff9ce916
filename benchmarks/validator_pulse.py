"""The validator's plain pulse-generator run (feedtune/validate/pulse_generator.py) against
a baseline revision's, side by side: CPU time and the arrays compared bit for bit.

Models over Tian's example box (δ = 430/140 000 rad, error limit 0.05–5 rad, k 100–5000 or
no acceleration law, f 50–200 kHz), step, ramp and sine commands; each model's run timed
in both versions, alternating which goes first::

    .venv/bin/python benchmarks/validator_pulse.py --baseline main --models 60 --rounds 2
"""

from __future__ import annotations

import argparse
import os
import sys
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(__file__))
from baseline import baseline_module, short_revision  # noqa: E402

from feedtune.loops.pulse_train import PulseInput, automatic_horizon  # noqa: E402
from feedtune.validate.pulse_generator import PulseModel  # noqa: E402

DELTA = 430.0 / 140e3  # rad per pulse (Tian §4)
KINDS = ("step", "step", "step", "ramp", "sine")


def models(count: int, seed: int = 0) -> list[tuple[dict, dict, float]]:
    """(plant, tuned, horizon [s]) over the example's box; every fifth without the law."""
    rng = np.random.default_rng(seed)
    out = []
    for i in range(count):
        value, frequency = rng.uniform(0.05, 5.0), rng.uniform(5e4, 2e5)
        ratio = rng.uniform(100.0, 5000.0) if i % 5 else None
        amplitude, kind = float(rng.choice([10.0, -10.0, 2.5, 0.3])), KINDS[i % len(KINDS)]
        horizon = (automatic_horizon(DELTA, frequency, value, ratio or 430.0,
                                     PulseInput("step", amplitude=amplitude))
                   if kind == "step" else 0.2)
        plant = {"type": "pulse_generator", "pulse_equivalent": DELTA, "input": kind,
                 "amplitude": amplitude, "ramp_velocity": amplitude, "sine_frequency": 20.0,
                 "acceleration_law": ratio is not None}
        tuned = {"sampling_frequency": frequency, "error_limit": value}
        if ratio is not None:
            tuned["acceleration_ratio"] = ratio
        out.append((plant, tuned, horizon))
    return out


def _timed(model) -> tuple[dict, float]:
    start = time.process_time()
    run = model.simulate()
    return run, time.process_time() - start


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", default="main")
    parser.add_argument("--models", type=int, default=60)
    parser.add_argument("--rounds", type=int, default=2)
    args = parser.parse_args()
    old = baseline_module(args.baseline, "feedtune/validate/pulse_generator.py", "baseline_pulse")
    cases = models(args.models)
    totals = {"baseline": 0.0, "this tree": 0.0}
    periods = 0
    for round_ in range(args.rounds):
        for index, (plant, tuned, horizon) in enumerate(cases):
            pair = [("baseline", old.PulseModel(plant, tuned, horizon)),
                    ("this tree", PulseModel(plant, tuned, horizon))]
            if (round_ + index) % 2:
                pair.reverse()
            runs = {}
            for name, model in pair:
                runs[name], cpu = _timed(model)
                totals[name] += cpu
            a, b = runs["baseline"], runs["this tree"]
            assert a["at_rest"] == b["at_rest"], index
            for key in ("reference", "pulses", "error"):
                assert a[key].dtype == b[key].dtype and a[key].tobytes() == b[key].tobytes(), \
                    (index, key)
            periods += a["pulses"].size
    print(f"{args.models} models x {args.rounds} rounds, {periods} periods; baseline "
          f"{short_revision(args.baseline)}: {totals['baseline']:.3f} s CPU, this tree: "
          f"{totals['this tree']:.3f} s CPU, ratio {totals['this tree'] / totals['baseline']:.3f}; "
          "every run's arrays and stop equal, bit for bit")
    return 0


if __name__ == "__main__":
    sys.exit(main())
