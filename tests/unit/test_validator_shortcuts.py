"""The validator's cheaper paths (issue 15, branch h-bval4) give the numbers of the paths
they replace: the step shape's dense grid from the drive's closed-form motion (was expm and
row products), the scans' e^{jωT} from cos and sin (was numpy's complex exp), a result
dumped without the fields no validator reads (was the whole dump)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import expm

from feedtune.schema.result import TuneResult
from feedtune.validate import sampled_frequency, validate_result
from feedtune.validate.software_servo import ServoModel, resolvent_position

#: (K [1/s], τ [s] or None, T [s], delay): Koren's example, a delay, Sato's ideal drive
LOOPS = [(25.0, 0.05, 0.01, 0), (12.0, 0.02, 0.004, 1), (30.0, None, 0.008, 0),
         (80.0, 0.01, 0.002, 0)]


@pytest.mark.parametrize("gain, tau, period, delay", LOOPS)
def test_the_step_shapes_grid_is_the_expm_grid(gain, tau, period, delay):
    """The dense grid of :class:`StepPosition` equals the drive's expm over a sub-step
    raised to each power and applied to the sample's state, to rounding (1e-14 of the
    largest position; the two differ by ≈ 1e-16 relative)."""
    model = ServoModel(gain, tau, period, delay)
    shape = sampled_frequency.StepPosition(model)
    a, b, _ = model.drive_matrices()
    m = a.shape[0]
    big = np.zeros((m + 1, m + 1))
    big[:m, :m], big[:m, m:] = a, b
    step = expm(big * period / sampled_frequency.SUBSTEPS)
    rows = [np.eye(m + 1)[0]]
    for _ in range(sampled_frequency.SUBSTEPS - 1):
        rows.append(rows[-1] @ step)
    dense = shape.starts @ np.array(rows).T
    assert np.max(np.abs(shape.dense - dense)) <= 1e-14 * np.max(np.abs(dense))
    # and each grid point is the closed-form position the refinements evaluate
    t = shape.times.ravel()[::97]
    assert np.allclose([shape(s) for s in t], shape.dense.ravel()[::97], rtol=0, atol=1e-14)


@pytest.mark.parametrize("gain, tau, period, delay", LOOPS)
def test_the_scans_exponential_is_numpys_complex_exp(gain, tau, period, delay):
    """The scans' open loop with e^{jωT} from cos and sin is the complex exp's to the bit,
    on a grid to twice Nyquist (numpy's exp of jωT calls the C library's cos and sin)."""
    model = ServoModel(gain, tau, period, delay)
    omega = np.geomspace(1e-3, 2 * np.pi / period, 2001)
    z = np.exp(1j * omega * period)
    old = gain * z ** (-delay) * resolvent_position(*model._resolvent_floats, z)
    new = model._grid_open_loop(omega)
    assert np.array_equal(new.view(float), old.view(float))


@pytest.mark.parametrize("name", ["bhatia-1971-hydraulic", "user-defined-sampled-drive",
                                  "ward-leonard-feed-drive", "tian-vf-pulse"])
def test_a_results_block_is_its_whole_dumps_block(name):
    """A TuneResult is validated on its dump without the fields no validator reads: the same
    block as from the whole dump (every entry, value and verdict)."""
    text = (Path(__file__).parents[1] / "data" / f"{name}.result.json").read_text()
    result = TuneResult.model_validate_json(text)
    whole = validate_result(result.model_dump(mode="json"))
    assert whole["covered"]
    assert json.dumps(validate_result(result)) == json.dumps(whole)
