"""Registry of validator models: plant type → model class, one module each."""

from __future__ import annotations

from feedtune.validate.model import Model, NotCovered
from feedtune.validate.hydraulic_rotary import HydraulicRotaryModel
from feedtune.validate.software_servo import ServoModel
from feedtune.validate.ward_leonard import WardLeonardModel

MODELS = {
    "software_servo": ServoModel,
    "hydraulic_rotary": HydraulicRotaryModel,
    "ward_leonard": WardLeonardModel,
}


def model_for(plant: dict, tuned: dict) -> Model:
    """The validator model of a result's plant spec (dict) at its tuned values (floats)."""
    kind = plant.get("type")
    if kind not in MODELS:
        raise NotCovered(f"plant type {kind!r} is not modelled by the validator")
    return MODELS[kind].from_result(plant, tuned)
