"""feedtune.frequency.first_crossing on a loop of numbers takes a float path (no graph of
if_else nodes is built); it must give what the symbolic path gives, to the last bit."""

import math

import casadi as ca
import pytest

from feedtune.frequency import first_crossing

BAND = (1e-2, 1e4)  # rad/s


def _gain(k):
    """|T|² of k/(s(s + 1) + k) [1], with a resonance for k > 1/2."""
    def gain(omega):
        re, im = k - omega**2, omega
        return k**2 / (re**2 + im**2)

    return gain


@pytest.mark.parametrize("k", [0.3, 2.0, 50.0, 1e6])
def test_numbers_give_the_symbolic_answer(k):
    x = ca.MX.sym("x")
    symbolic = first_crossing(lambda w: _gain(k + 0 * x)(w), BAND, 0.5)
    expected = float(ca.Function("f", [x], [symbolic])(0.0))
    assert float(ca.evalf(first_crossing(_gain(k), BAND, 0.5))) == expected


def test_no_crossing_in_the_band_is_its_top():
    assert float(ca.evalf(first_crossing(lambda w: 1 + 0 * w, BAND, 0.5))) == pytest.approx(
        BAND[1], rel=1e-12)


def test_the_crossing_is_the_half_power_point():
    """The overdamped loop k = 0.3: |T|² = 1/2 found by plain bisection in floats."""
    gain = _gain(0.3)
    lo, hi = 1e-2, 1e4
    for _ in range(200):
        mid = math.sqrt(lo * hi)
        lo, hi = (mid, hi) if gain(mid) > 0.5 else (lo, mid)
    assert float(ca.evalf(first_crossing(gain, BAND, 0.5))) == pytest.approx(lo, rel=1e-12)
