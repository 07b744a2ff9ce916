"""Velocity error constant C_v (Bhatia 1971 Ch. IV eq 2; Koren 1979 eq 5)."""

from feedtune.loops.protocols import Capability, Loop
from feedtune.objectives.base import Metric


class VelocityConstant(Metric):
    """C_v = lim s·L(s) [1/s]: feed velocity per following error of a type-1 loop."""

    name = "velocity_constant"
    unit = "1/s"
    description = "Velocity error constant C_v = lim s L(s); following error = feed / C_v"
    reference = "Bhatia 1971 Ch. IV eq 2 (C_v ≥ 80); Koren 1979 eq 5"

    def supports(self, loop: Loop, options=None):
        return loop.offers(Capability.VELOCITY_CONSTANT)

    def evaluate(self, loop: Loop, options):
        return loop.velocity_constant
