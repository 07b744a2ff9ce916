"""Slowest decay rate of the closed-loop poles (MATLAB ``TuningGoal.Poles``, MinDecay)."""

import math

from feedtune.loops.protocols import Capability, Loop
from feedtune.objectives.base import Metric
from feedtune.objectives.poles.pole_region import (decay_conditions, decay_factor_conditions,
                                                   decay_of, pole_region)


class DecayRate(Metric):
    """σ_min = min over the closed-loop poles of −Re p [1/s]; a sampled loop's z-poles
    through p = ln(z)/T. Every mode decays at least as fast as e^{−σ_min t}.

    The NLP holds σ_min ≥ σ by the Hurwitz conditions of p(s − σ) (sampled: the Schur
    conditions of p(e^{−σT} z)), and maximises it by an epigraph variable held by the same
    conditions; it can be bounded from below and maximised, not bounded from above or
    minimised. The value is computed from the numeric poles (numpy eigenvalues).
    """

    name = "decay_rate"
    unit = "1/s"
    description = ("Slowest decay rate min(-Re p) of the closed-loop poles [1/s] (sampled "
                   "loops: p = ln(z)/T); 'min' bounds and 'maximize' only")
    reference = "MATLAB TuningGoal.Poles (MinDecay); Hurwitz conditions of p(s - sigma)"
    direction = "min"

    def supports(self, loop: Loop, options=None):
        return super().supports(loop, options) and loop.offers(Capability.LINEAR)

    def evaluate(self, loop: Loop, options):
        return pole_region(loop, decay_of, decay_conditions(loop), 0.0, math.inf,
                           decay_factor_conditions)
