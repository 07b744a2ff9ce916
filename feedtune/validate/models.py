"""Registry of validator models: plant type → model class, one module each."""

from __future__ import annotations

from feedtune.validate.model import Model, NotCovered
from feedtune.validate.software_servo import ServoModel

MODELS = {
    "software_servo": ServoModel,
}


def model_for(plant: dict, tuned: dict) -> Model:
    """The validator model of a result's plant spec (dict) at its tuned values (floats)."""
    kind = plant.get("type")
    if kind not in MODELS:
        raise NotCovered(f"plant type {kind!r} is not modelled by the validator")
    return MODELS[kind].from_result(plant, tuned)
