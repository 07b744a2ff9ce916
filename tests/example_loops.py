"""Loops of numbers of a bundled Koren example at seeded points of its box, for the tests of
what a loop of numbers reports (tests/unit/test_replayed_steps.py, test_report_numbers.py)."""

import math
from pathlib import Path

import numpy as np

from feedtune.problem import build_plant, resolve_tunables
from feedtune.schema.spec import parse_spec

REPO = Path(__file__).resolve().parents[1]
KINDS = {"pulse": "koren-1979-reference-pulse", "sampled": "koren-1979-sampled-data"}


def example_loops(kind: str, count: int, seed: int) -> list:
    """``count`` loops of numbers of the example ``KINDS[kind]`` at log-uniform points of
    its box, drawn with ``numpy.random.default_rng(seed)``."""
    spec = parse_spec((REPO / "examples" / f"{KINDS[kind]}.json").read_text())
    plant = build_plant(spec)
    _, _, box = resolve_tunables(spec, plant)
    rng = np.random.default_rng(seed)
    return [plant.loop({name: math.exp(rng.uniform(math.log(lo), math.log(hi)))
                        for name, (lo, hi) in box.items()}, box) for _ in range(count)]
