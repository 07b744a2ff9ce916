"""Registry of validator models: plant type → model class, one module each."""

from __future__ import annotations

from feedtune.validate.hydraulic_rotary import HydraulicRotaryModel
from feedtune.validate.linear import LinearModel
from feedtune.validate.model import Model, NotCovered
from feedtune.validate.pulse_generator import PulseModel
from feedtune.validate.software_servo import ServoModel
from feedtune.validate.ward_leonard import WardLeonardModel

MODELS = {
    "software_servo": ServoModel,
    "hydraulic_rotary": HydraulicRotaryModel,
    "ward_leonard": WardLeonardModel,
    "pulse_generator": PulseModel,
    "linear": LinearModel,
}


def model_for(plant: dict, tuned: dict, stability: dict | None = None) -> Model:
    """The validator model of a result's plant spec (dict) at its tuned values (floats);
    ``stability``: the result's block (the pulse generator's simulated horizon)."""
    kind = plant.get("type")
    if kind not in MODELS:
        raise NotCovered(f"plant type {kind!r} is not modelled by the validator")
    return MODELS[kind].from_result(plant, tuned, stability or {})
