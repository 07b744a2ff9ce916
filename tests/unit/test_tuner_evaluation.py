"""feedtune.tuner.evaluation: what the NLP sees at a point, and the scales from the starts."""

import math

import casadi as ca
import numpy as np
import pytest

from feedtune.expr import Magnitude, Supremum
from feedtune.loops.frequency import peak
from feedtune.tuner.evaluation import Evaluator, Scales, Seen, smallest_magnitudes
from feedtune.tuner.supremum import make_scan


def _seen(objective, terms, bounds, stability, settling=()):
    return Seen(objective, terms, bounds, np.array(stability, dtype=float),
                np.array(settling, dtype=float), {})


def test_scales_are_the_smallest_magnitudes_over_the_stable_starts_only():
    seen = [_seen(0.25, [5.0], [0.5], [0.5]), _seen(4.0, [-20.0], [2.0], [3.0]),
            _seen(9.0, [0.1], [0.01], [-2.0])]  # the third start is unstable
    assert smallest_magnitudes(seen) == Scales(objective=0.25, terms=[5.0], bounds=[0.5],
                                               stability=[0.5], settling=[])


def test_no_stable_start_gives_no_scale_and_zero_is_no_scale():
    seen = [_seen(1.0, [0.0], [None], [-1.0])]
    scales = smallest_magnitudes(seen)
    assert scales.objective is None and scales.terms == [None] and scales.bounds == [None]
    assert scales.stability == [1.0]


def test_evaluator_names_every_value_and_scans_the_peak():
    """Terms 2·|k − 3| and k; a bound on the peak of k·ω/(1 + ω²) (k/2 at ω = 1 rad/s)."""
    z = ca.MX.sym("z", 1)
    p = ca.MX.sym("p", 1)  # a plant number: the loop's gain k·p
    k = ca.exp(z[0]) * p

    def fn(omega):
        return k * omega / (1 + omega**2)

    value, where = peak(fn, (0.01, 100.0))
    supremum = Supremum(fn, np.geomspace(0.01, 100.0, 161), value, where)
    scan = make_scan("peak", supremum, z, p)
    evaluator = Evaluator(z, p, [Magnitude(k - 3), k], [2.0, 1.0], [None, None], [supremum],
                          [scan], [1 - k / 10], [], {"closed_loop": ca.reshape(-k, 1, 1)})
    seen = evaluator(np.array([math.log(2.0)]), np.array([1.0, 99.0]))  # extra p ignored
    assert seen.terms == [1.0, 2.0] and seen.objective == pytest.approx(4.0)
    assert seen.bounds[0] == pytest.approx(1.0, rel=1e-12)
    np.testing.assert_allclose(seen.stability, [0.8])
    np.testing.assert_allclose(seen.matrices["closed_loop"], [[-2.0]])
