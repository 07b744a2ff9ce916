"""Smallest damping ratio of the closed-loop poles (MATLAB ``TuningGoal.Poles``, MinDamping)."""

from feedtune.loops.protocols import Capability, Loop
from feedtune.objectives.base import Metric
from feedtune.objectives.poles.pole_region import (damping_conditions, damping_factor_conditions,
                                                   damping_of, pole_region)


class PoleDamping(Metric):
    """ζ_min = min over the closed-loop poles of −Re p/|p| [1] (a real pole: 1); a sampled
    loop's z-poles through p = ln(z)/T, as MATLAB's ``damp``.

    Unlike ``damping_ratio`` (the pole pair of a second-order loop, Koren eqs 9 and 19) it
    reads every pole of any linear loop. On a continuous loop the NLP holds ζ_min ≥ ζ by
    the Hurwitz conditions of p(e^{jα}s)·p(e^{−jα}s), α = arcsin ζ, and maximises it by an
    epigraph variable held by the same conditions; bounded from below and maximised only.
    On a sampled loop it is reported only (see :meth:`optimisable`). The value is computed
    from the numeric poles (numpy eigenvalues).
    """

    name = "pole_damping"
    unit = "1"
    description = ("Smallest damping ratio min(-Re p/|p|) of the closed-loop poles [1] "
                   "(sampled loops: p = ln(z)/T); 'min' bounds and 'maximize' only")
    reference = "MATLAB TuningGoal.Poles (MinDamping); Hurwitz conditions of p(e^{ja}s)p(e^{-ja}s)"
    direction = "min"

    def supports(self, loop: Loop, options=None):
        return super().supports(loop, options) and loop.offers(Capability.LINEAR)

    def optimisable(self, loop: Loop, options=None):
        """Continuous loops only: on a sampled loop the region ζ ≥ ζ0 is bounded by a
        logarithmic spiral in the z-plane, which no polynomial (Schur) test describes, so
        the NLP has no smooth rows for it; the value is reported on the tuned design."""
        return not loop.discrete

    def evaluate(self, loop: Loop, options):
        return pole_region(loop, damping_of, damping_conditions(loop), 0.0, 1.0,
                           None if loop.discrete else damping_factor_conditions)
