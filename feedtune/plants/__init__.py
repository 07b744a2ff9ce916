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


def plant_for(params):
    """The plant object for a spec's ``plant`` section (its ``type`` picks the class)."""
    return PLANTS[params.type](params)
