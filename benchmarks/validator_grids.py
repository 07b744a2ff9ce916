"""The reference tests' validator grids, side by side with an older revision's package.

tests/reference/test_robust_tuning.py re-measures Bhatia's robust design at 241 inertias
and tests/reference/test_robust_plants.py the Ward-Leonard robust design at 241 inertias
and the linear drive's at 41 × 41 (dead time, s² coefficient), each with
``feedtune.validate``'s own models. This script tunes those designs once (with this
checkout), then in fresh processes, this checkout's package and ``--baseline``'s in turn,
builds each grid's models and measures M_peak (and the other frequency measures of every
10th model), and prints the CPU of each per round, the ratio and how many numbers are the
same bits.

    .venv/bin/python benchmarks/validator_grids.py --baseline main --rounds 3
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(REPO), str(REPO / "tests" / "reference"), str(REPO / "tests")]

from benchmarks.baseline import numbers_side_by_side  # noqa: E402

CHILD = r"""
import numpy as np
from feedtune.schema.uncertainty import with_numbers
from feedtune.validate.models import model_for
designs = json.load(open({designs!r}))
#: what the tests measure on each grid; every 10th model all of them
MEASURES = ("m_peak", "phase_margin", "sensitivity_peak", "bandwidth", "crossover",
            "gain_margin")
GRIDS = (("bhatia", 1, [{{"inertia": j}} for j in np.linspace(0.7 * 0.0135582,
                                                            1.3 * 0.0135582, 241)]),
         ("ward_leonard", 1, [{{"inertia": j}} for j in np.linspace(5.0, 15.0, 241)]),
         ("linear", 2, [{{"dead_time": t, "model.denominator.2": a}}
                        for t in np.linspace(1e-4, 4e-4, 41)
                        for a in np.linspace(4.2, 7.8, 41)][::{stride}]))
for name, _, grid in GRIDS:  # imports and first calls outside the clock
    model = model_for(with_numbers(designs[name]["plant"], grid[0]), designs[name]["tuned"],
                      designs[name]["stability"])
    for measure in MEASURES:
        getattr(model, measure)()
values, cpu = [], {{}}
for name, measured, grid in GRIDS:
    design = designs[name]
    start = time.process_time()
    for k, point in enumerate(grid):
        model = model_for(with_numbers(design["plant"], point), design["tuned"],
                          design["stability"])
        for measure in MEASURES if k % 10 == 0 else MEASURES[:measured]:
            try:
                values.append(float(getattr(model, measure)()))
            except Exception:
                values.append(float("nan"))
    cpu[name] = round(time.process_time() - start, 3)
print(cpu, file=sys.stderr)
print(json.dumps({{"cpu": sum(cpu.values()), "values": values}}))
"""


def designs(path: Path) -> None:
    """The three robust designs the tests re-measure, tuned by this checkout."""
    from conftest import load_example, tune_dict
    import test_robust_plants as plants

    out = {}
    specs = {"bhatia": load_example("bhatia-1971-robust-inertia"),
             "ward_leonard": plants._ward_leonard(True), "linear": plants._linear(True)}
    for name, spec in specs.items():
        result = tune_dict(spec)
        out[name] = {"plant": result.spec["plant"], "stability": result.stability,
                     "tuned": {k: t.value for k, t in result.tuned.items()}}
    path.write_text(json.dumps(out))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", default="main")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--stride", type=int, default=4,
                        help="every STRIDE-th point of the linear drive's 1 681 (default 4)")
    args = parser.parse_args()
    from feedtune.__main__ import pin_blas_threads

    pin_blas_threads()
    path = Path(tempfile.mkdtemp()) / "designs.json"
    designs(path)
    numbers_side_by_side(CHILD, args.baseline, args.rounds, designs=str(path),
                         stride=args.stride)


if __name__ == "__main__":
    main()
