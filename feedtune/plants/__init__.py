"""Registry of plants: spec ``plant.type`` → class. Add a plant here and in its own module."""

from feedtune.plants.hydraulic_rotary import HydraulicRotary
from feedtune.plants.linear import Linear
from feedtune.plants.pulse_generator import PulseGenerator
from feedtune.plants.software_servo import SoftwareServo
from feedtune.plants.ward_leonard import WardLeonard

PLANTS = {
    "software_servo": SoftwareServo,
    "hydraulic_rotary": HydraulicRotary,
    "ward_leonard": WardLeonard,
    "pulse_generator": PulseGenerator,
    "linear": Linear,
}

#: plants known only by measured data, tuned by the ``convex`` technique rather than the NLP
#: (no Loop): type → the module that reads them, imported when a spec names one (it loads
#: numpy). feedtune.schema.spec.parse_spec hands their specs to
#: feedtune.measured.datadriven_spec, feedtune.problem.tune to its tune_data_driven.
DATA_PLANTS = {"frequency_response_data": "feedtune.plants.frequency_response_data"}


def plant_for(params):
    """The plant object for a spec's ``plant`` section (its ``type`` picks the class)."""
    return PLANTS[params.type](params)
