"""Ward-Leonard tunings from one start (issue 15): the bundled spec and two random variants.

The variants are ``benchmarks/bhatia_speed.py``'s ``variants("ward-leonard-feed-drive")``
01 and 08 (seed 15), stored in tests/data so that the test does not depend on the
benchmark's random numbers. Before the tuner kept its iterates stable and warm-started its
exchange rounds, both ended at closed loops with right-half-plane poles (01: 19.4 ± 22.5j
rad/s, 08: 26.4 ± 30.4j rad/s) reported infeasible. Each result is checked by the
project's validator (its own numpy/scipy model), and its poles independently here.
"""

import json
from pathlib import Path

import numpy as np
import pytest

from conftest import load_example, tune_dict

DATA = Path(__file__).resolve().parents[1] / "data"
#: the issue's "reaches its best-known optimum": bandwidth within this of it (relative)
REACHED_RTOL = 1e-4
#: best-known bandwidths [rad/s]: variant 01's from 8 starts of the previous tuner
#: (benchmarks/bhatia_speed.py REFERENCE); the bundled spec's is this tuner's, above the
#: 25.5571 rad/s that 8 starts of the previous tuners reached
BEST = {"ward-leonard-feed-drive": 25.562727141970303,
        "ward-leonard-feed-drive-variant01": 21.012053724738568}


def spec(name: str) -> dict:
    if name == "ward-leonard-feed-drive":
        return load_example(name)
    return json.loads((DATA / f"{name}.json").read_text())


@pytest.fixture(scope="module")
def tuned():
    cache = {}

    def get(name):
        if name not in cache:
            cache[name] = tune_dict(spec(name))
        return cache[name]

    return get


@pytest.mark.parametrize("name", ["ward-leonard-feed-drive", "ward-leonard-feed-drive-variant01",
                                  "ward-leonard-feed-drive-variant08"])
def test_one_start_ends_at_a_stable_validated_optimum(tuned, name):
    result = tuned(name)
    assert len(result.solver.starts) == 1
    assert result.success and result.status == "optimal", result.message
    assert result.validation["ok"]
    assert all(c.satisfied for c in result.constraints)
    poles = np.array(result.stability["poles"])
    inner = np.array(result.stability["inner_loop"]["poles"])
    assert np.all(poles[:, 0] < 0) and np.all(inner[:, 0] < 0)


@pytest.mark.parametrize("name", sorted(BEST))
def test_one_start_reaches_the_best_known_bandwidth(tuned, name):
    assert tuned(name).metrics["bandwidth"].value >= BEST[name] * (1 - REACHED_RTOL)
