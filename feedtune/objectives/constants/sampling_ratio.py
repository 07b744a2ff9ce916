"""Sampling period over drive time constant, T/τ (Koren eqs 22–23)."""

from feedtune.loops.protocols import Loop
from feedtune.objectives.base import Metric


class SamplingRatio(Metric):
    """T/τ [1]; must stay below π (eq 22), Koren recommends ≈ π/4 (eq 23)."""

    name = "sampling_ratio"
    unit = "1"
    description = "Sampling period over drive time constant, T/τ"
    reference = "Koren 1979 eqs 22, 23"

    def supports(self, loop: Loop, options=None):
        return loop.discrete and loop.drive.time_constant is not None

    def evaluate(self, loop: Loop, options):
        return loop.period / loop.drive.time_constant
