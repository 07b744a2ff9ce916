"""Registry of plants: spec ``plant.type`` → class. Add a plant here and in its own module.

:data:`PLANT_PATHS` names each plant's class by module, and :func:`plant_class` imports
one: checking a spec imports the plant it names, not the others (issue 15's start-up).
``PLANTS`` (type → class, a dict) imports every plant's module when first read.
"""

from feedtune.lazy import load

#: plant type → its class, as "module:Class"
PLANT_PATHS = {
    "software_servo": "feedtune.plants.software_servo:SoftwareServo",
    "hydraulic_rotary": "feedtune.plants.hydraulic_rotary:HydraulicRotary",
    "ward_leonard": "feedtune.plants.ward_leonard:WardLeonard",
    "pulse_generator": "feedtune.plants.pulse_generator:PulseGenerator",
    "linear": "feedtune.plants.linear:Linear",
}

#: plants known only by measured data, tuned by the ``convex`` technique rather than the NLP
#: (no Loop): type → the module that reads them, imported when a spec names one (it loads
#: numpy). feedtune.schema.spec.parse_spec hands their specs to
#: feedtune.measured.datadriven_spec, feedtune.problem.tune to its tune_data_driven.
DATA_PLANTS = {"frequency_response_data": "feedtune.plants.frequency_response_data"}


def plant_class(plant_type: str) -> type:
    """The class of plant ``plant_type`` (a key of :data:`PLANT_PATHS`), its module
    imported now."""
    return load(PLANT_PATHS[plant_type])


def plant_for(params):
    """The plant object for a spec's ``plant`` section (its ``type`` picks the class)."""
    return plant_class(params.type)(params)


def __getattr__(name: str):
    """``PLANTS``: plant type → class, every plant's module imported on first read."""
    if name != "PLANTS":
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    plants = globals()["PLANTS"] = {key: plant_class(key) for key in PLANT_PATHS}
    return plants
