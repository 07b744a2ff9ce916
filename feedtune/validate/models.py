"""Registry of validator models: plant type → model class, one module each.

:data:`MODEL_PATHS` names each plant type's model by module, and :func:`model_for` imports
the one a result's plant needs: a tuning (``feedtune tune``, a batch worker) loads only its
own plant's validator, not the other plants' (with their scipy imports; issue 15's
start-up).
"""

from __future__ import annotations

import importlib

from feedtune.validate.model import Model, NotCovered

#: plant type → its validator model, as "module:Class"
MODEL_PATHS = {
    "software_servo": "feedtune.validate.software_servo:ServoModel",
    "hydraulic_rotary": "feedtune.validate.hydraulic_rotary:HydraulicRotaryModel",
    "ward_leonard": "feedtune.validate.ward_leonard:WardLeonardModel",
    "pulse_generator": "feedtune.validate.pulse_generator:PulseModel",
    "linear": "feedtune.validate.linear:LinearModel",
}


def model_for(plant: dict, tuned: dict, stability: dict | None = None) -> Model:
    """The validator model of a result's plant spec (dict) at its tuned values (floats);
    ``stability``: the result's block (the pulse generator's simulated horizon)."""
    kind = plant.get("type")
    if kind not in MODEL_PATHS:
        raise NotCovered(f"plant type {kind!r} is not modelled by the validator")
    return model_class(kind).from_result(plant, tuned, stability or {})


def model_class(kind: str) -> type[Model]:
    """The validator model of plant type ``kind`` (a key of :data:`MODEL_PATHS`), its module
    imported now (by ``importlib``: :mod:`feedtune.lazy` also holds the tuner's CasADi,
    which no validator module may import; tests/architecture)."""
    module, _, name = MODEL_PATHS[kind].partition(":")
    return getattr(importlib.import_module(module), name)

