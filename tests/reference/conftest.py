"""Shared helpers for the reference tests: load a bundled example and tune it."""

import copy
import json
from pathlib import Path

import pytest

from feedtune.problem import tune
from feedtune.spec import parse_spec

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def load_example(name: str) -> dict:
    return json.loads((EXAMPLES / f"{name}.json").read_text())


def tune_dict(spec: dict):
    return tune(parse_spec(copy.deepcopy(spec)))


@pytest.fixture(scope="session")
def tuned_example():
    cache = {}

    def get(name):
        if name not in cache:
            cache[name] = tune_dict(load_example(name))
        return cache[name]

    return get
