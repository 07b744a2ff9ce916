"""Bundled example specs for the solver- and structure-reuse tests, and results compared
without their timings."""

import json
from pathlib import Path

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
TIMING = ("solve_time", "build_time", "evaluation_time")
#: examples whose one free gain IPOPT would not solve unless asked to
ONE_GAIN = ("koren-1979-min-iae-radius.json", "koren-1979-sampled-data.json",
            "koren-1979-reference-pulse.json")


def load_example(name: str) -> dict:
    """The bundled spec ``name`` as a dict; Koren's one-gain examples with an IPOPT option,
    so that they build a solver (one free gain goes to the scalar search, and one free gain
    with one |e| to the root search, which build none; the option given is IPOPT's default
    here: same results)."""
    data = json.loads((EXAMPLES / name).read_text(encoding="utf-8"))
    if name in ONE_GAIN:
        data["solver"]["ipopt_options"] = {"hessian_approximation": "exact"}
    return data


def without_timing(result) -> dict:
    """The result as JSON data without its wall-clock times."""
    data = result.model_dump(mode="json")
    for key in TIMING:
        data["solver"].pop(key)
    for start in data["solver"]["starts"]:
        start.pop("solve_time")
    return data
