"""The validator's linear model (``feedtune/validate/linear.py``): M_peak and phase margin
of the user-defined drive over a grid of dead times and inertias, new against a git
revision's module, side by side in one process (issue 15).

``tests/reference/test_robust_plants.py`` re-measures a robust design on 41 × 41 plants
this way (≈ 1 700 models, each M_peak and phase margin): each model's frequency response
is the new one's and the baseline's in turn, and both must give the same bits.

    .venv/bin/python benchmarks/validator_linear_response.py [--baseline main] [--points 21]
"""

from __future__ import annotations

import argparse
import copy
import json
import sys
import time
from pathlib import Path

from baseline import baseline_module

REPO = Path(__file__).resolve().parents[1]
MODULE = "feedtune/validate/linear.py"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", default="main", help="git revision of the old module")
    parser.add_argument("--points", type=int, default=21, help="grid points per parameter")
    args = parser.parse_args()
    from feedtune.__main__ import pin_blas_threads

    pin_blas_threads()
    import numpy as np

    from feedtune.schema.uncertainty import with_numbers
    from feedtune.validate.linear import LinearModel
    from feedtune.validate.models import model_for

    old = baseline_module(args.baseline, MODULE, "baseline_validate_linear")
    spec = json.loads((REPO / "examples" / "user-defined-drive.json").read_text())
    tuned = {name: t.get("initial", t.get("value")) for name, t in spec["tunables"].items()}
    points = [{"dead_time": theta, "model.denominator.2": a}
              for theta in np.linspace(1e-4, 4e-4, args.points)
              for a in np.linspace(4.2, 7.8, args.points)]
    models = [model_for(with_numbers(spec["plant"], p), tuned) for p in points]
    assert all(isinstance(m, LinearModel) for m in models)
    cpu = {"new": 0.0, "old": 0.0}
    for model in models:
        for label in ("old", "new"):
            m = copy.copy(model)
            if label == "old":
                m.__class__ = old.LinearModel
            start = time.process_time()
            values = (m.m_peak(), m.phase_margin())
            cpu[label] += time.process_time() - start
            if label == "old":
                expected = values
        assert values == expected, (values, expected)  # the same bits
    print(f"{len(models)} models, M_peak and phase margin each: new {cpu['new']:.2f} s, "
          f"old {cpu['old']:.2f} s of CPU, new/old {cpu['new'] / cpu['old']:.3f}; same bits")


if __name__ == "__main__":
    sys.exit(main())
