"""Shared helpers for the reference tests: load a bundled example and tune it."""

import copy
import json
from pathlib import Path

import pytest

from feedtune.problem import tune
from feedtune.schema.spec import parse_spec

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def load_example(name: str) -> dict:
    return json.loads((EXAMPLES / f"{name}.json").read_text())


def tune_dict(spec: dict):
    return tune(parse_spec(copy.deepcopy(spec)))


@pytest.fixture(scope="session")
def tuned_example(tuned):
    """``tuned_example(name)``: the bundled example ``name`` tuned, once per test process
    (the ``tuned`` fixture of tests/conftest.py)."""
    return lambda name: tuned(load_example(name))


#: the optimum `feedtune tune` finds for each bundled example (measured with the bundled spec;
#: see test_export_control.py): tests that only evaluate fix the tunables at these values
TUNED = {
    "bhatia-1971-hydraulic": {
        "position_gain": 263.7033733791451, "velocity_gain": 1000.0000688232861,
        "velocity_compensator.tau1": 0.09122719628730186,
        "velocity_compensator.tau2": 0.09122719628730348,
        "velocity_compensator.tau12": 100.00000454929132,
        "position_compensator.tau1": 9.999999090636816e-05,
        "position_compensator.tau2": 9.999999090636816e-05,
        "position_compensator.tau12": 0.004350557048934217},
    # the robust design over J_t ± 30 % (tests/reference/test_robust_tuning.py)
    "bhatia-1971-robust-inertia": {
        "position_gain": 217.31344359835865, "velocity_gain": 1000.0000660011096,
        "velocity_compensator.tau1": 0.07936752692421944,
        "velocity_compensator.tau2": 0.07936752692421885,
        "velocity_compensator.tau12": 100.00000459947526,
        "position_compensator.tau1": 9.999999080903111e-05,
        "position_compensator.tau2": 9.999999080903111e-05,
        "position_compensator.tau12": 0.004561186559678419},
    "ward-leonard-feed-drive": {
        "position_gain": 1000.000063749983, "velocity_gain": 905.325213845655,
        "velocity_compensator.tau1": 0.6016647294655322,
        "velocity_compensator.tau2": 0.6016647294655322,
        "velocity_compensator.tau12": 100.0000045639364,
        "position_compensator.tau1": 0.3370152041330752,
        "position_compensator.tau2": 0.33701520413306374,
        "position_compensator.tau12": 100.00000412534224},
    "koren-1979-encoder-limit": {"position_gain": 38.55622513822891,
                                 "sampling_period": 0.012499999882021723},
    "koren-1979-iae-natural": {"position_gain": 28.48968885097107},
    "koren-1979-min-iae-radius": {"position_gain": 22.169033028950597, "sampling_period": 0.01},
    "koren-1979-reference-pulse": {"position_gain": 25.24999999999964},
    "koren-1979-sampled-data": {"position_gain": 18.17336280332592, "sampling_period": 0.015625},
    "sato-finish": {"position_gain": 43.83990622444932, "sampling_period": 0.0019999999348473824,
                    "reference_interval": 0.009999999627665394},
    "sato-table2-a": {"position_gain": 40.0, "sampling_period": 0.002,
                      "reference_interval": 0.2617993877991494},
    "sato-table2-b": {"position_gain": 40.0, "sampling_period": 0.002,
                      "reference_interval": 0.1308996938995747},
    "sato-throughput": {"position_gain": 49.65629088022349, "sampling_period": 0.002,
                        "reference_interval": 0.026308003854479553},
}
