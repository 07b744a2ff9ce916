"""Bhatia's sensitivity |G K'_v K'_p| (Ch. IV eq 1)."""

from feedtune.loops.protocols import Capability, Loop
from feedtune.objectives.base import Metric


class Sensitivity(Metric):
    """|G(0) K'_v K'_p| [1/s]: the loop-gain product that makes the closed loop insensitive
    to the plant; 1000 for a sensitivity S_G of 0.1 % (Bhatia Ch. IV eq 1)."""

    name = "sensitivity"
    unit = "1/s"
    description = "Loop-gain product |G(0) K'_v K'_p| (Bhatia's sensitivity; >= 1000 for 0.1 %)"
    reference = "Bhatia 1971 Ch. IV eq 1"

    def supports(self, loop: Loop, options=None):
        return loop.offers(Capability.LOOP_GAIN_PRODUCT)

    def evaluate(self, loop: Loop, options):
        return loop.loop_gain_product
