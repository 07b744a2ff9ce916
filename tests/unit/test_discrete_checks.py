"""tests/discrete_checks.py's ``response``: a state space's values in one stacked solve are
python-control's own, to the bit (the references that read it are python-control's)."""

import math

import control
import numpy as np
import pytest

from discrete_checks import response


@pytest.mark.parametrize("states", [1, 2, 3, 5, 8])
@pytest.mark.parametrize("period", [0, 0.01])
def test_a_state_spaces_response_is_python_controls_to_the_bit(states, period):
    for seed in range(5):
        np.random.seed(1000 * states + seed)  # python-control's rss draws from numpy's
        system = control.drss(states, 1, 1, dt=period) if period else control.rss(states, 1, 1)
        omega = np.geomspace(1e-3, math.pi / period if period else 1e4, 501)
        points = np.exp(1j * omega * period) if period else 1j * omega
        assert np.array_equal(response(system, points), np.asarray(system(points)).ravel())
        transfer = control.ss2tf(system)
        assert np.array_equal(response(transfer, points), np.asarray(transfer(points)).ravel())
