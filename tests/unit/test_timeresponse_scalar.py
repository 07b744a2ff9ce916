"""The scalar evaluation Brent's method calls (Transient._scalar) is the array path's value
to the last bit: crossings, extrema and settling times do not move by its speed-up.

Transfers: Bhatia's eighth-order compensated loop (tests/unit/test_timeresponse.py, its
BHATIA_S), a repeated complex pair (one cluster with a nilpotent part), a pair 1e-6 apart
(a cluster with a long series) and a lightly damped second-order error. Times: the grid,
points between grid points and past every cluster's cutoff (where clusters drop out).
"""

from __future__ import annotations

import numpy as np
import pytest

from feedtune.loops.timeresponse import reference_error, step_response

BHATIA_S = ([1.97529877e-14, 1.57283724e-10, 2.64851296e-07, 6.50176953e-05, 1.35768455e-02,
             1.47826611e+00, 5.80829416e+01, 3.01000326e+02, 0.0],
            [1.97529877e-14, 1.57283724e-10, 2.64851296e-07, 6.50176953e-05, 1.38435112e-02,
             1.76693170e+00, 1.22899410e+02, 3.97099551e+03, 2.40000260e+04])
QUAD = np.array([1.0, 2 * 0.2 * 30.0, 30.0**2])
CLOSE = np.array([1.0, 2 * 0.2 * 30.0 * (1 + 1e-6), 30.0**2 * (1 + 1e-6)])


def transients():
    yield reference_error(*BHATIA_S).transient
    for other in (QUAD, CLOSE):
        den = np.polymul(QUAD, other)
        yield step_response([den[-1]], den).transient
    yield reference_error([1.0, 2 * 0.02 * 5.0, 0.0], [1.0, 2 * 0.02 * 5.0, 25.0]).transient


@pytest.mark.parametrize("kind", ["value", "derivative", "integral", "double_integral"])
def test_scalar_is_the_array_path_bit_for_bit(kind):
    rng = np.random.default_rng(15)
    checked = 0
    for tr in transients():
        grid = tr.grid
        times = np.concatenate([grid[::max(1, len(grid) // 400)],
                                rng.uniform(0, tr.span, 400),
                                [cl.cutoff for cl in tr.clusters],
                                [cl.cutoff * (1 + 1e-12) for cl in tr.clusters],
                                [tr.span * 2, 0.0]])
        scalar = tr._scalar(kind)
        for t in times:
            assert scalar(float(t)) == float(tr._sum(kind, np.array([t]))[0])
            checked += 1
    assert checked > 3000
