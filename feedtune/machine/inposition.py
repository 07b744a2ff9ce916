"""The in-position wait at exact stops: the next block waits for the axes to settle.

At an exact stop (G9, G61, a rapid's end, the program's end) the interpolator brings the
*reference* to rest; the axes arrive later, lagging by their following error, and a loop
whose ramp response overshoots carries the table past the stop and back. A control with an
in-position check holds the next block until every axis' following error is within the
in-position band (the "in-position width" of a CNC's servo parameters). Bhatia 1971,
§IV.H, on the sharp corner at B of Fig 38: "The execution of the next block is started
from rest. The slight overshoot indicated in the figure occurs while the table seeks a
null position at B."

The hold at a stop is the first interpolation instant after which the following error of
every axis stays within ``band`` while the reference holds there: the table has settled,
at rest to within the band. (Its error merely being within the band once is not enough:
Bhatia's drive crosses null 14 ms after the stop at full speed on its way to a 60 µm
overshoot; a control checks in-position and zero speed, which this is.)

How, without anything flowing back into a loop: every axis is linear and time-invariant,
so its following error over the program is the sum of the errors of the pieces of motion
between stops, each simulated once from rest (:func:`~feedtune.machine.simulate.
simulate_lti`, its displacement from its start, held at the end for the axes' run-out),
shifted to where the piece starts. Piece p starts where the hold of stop p − 1 ends, which
only the pieces before it decide: the holds are found one stop after another by adding
each piece's error into the running sum and reading where it leaves the band for the
last time. The result is a reference (:func:`~feedtune.machine.interpolate.join`) that
the machine simulation runs like any other: the axes never see anything but a reference.
The cost is one extra simulation of every piece and its run-out.

Independent axes only: a cross-coupled controller's loop follows the path's direction,
so it is not time-invariant and the sum does not hold (the machine spec refuses both).
"""

from __future__ import annotations

import math

import numpy as np

from feedtune.machine.interpolate import MAX_SAMPLES, join, stop_pieces
from feedtune.machine.path import Path, Reference
from feedtune.machine.simulate import AxisModel, axis_inputs, run_out_samples, simulate_lti


def piece_error(models: list[AxisModel], piece: Reference, tail: int) -> np.ndarray:
    """Following error [m] (len(piece) + ``tail``, axes) of the axes starting at rest at
    the piece's first point, the reference held at its last point for ``tail`` samples."""
    count = len(models)
    moved = piece.position[:, :count] - piece.position[0, :count]
    moved = np.vstack([moved, np.repeat(moved[-1:], tail, axis=0)])
    error = np.empty_like(moved)
    for i, model in enumerate(models):
        error[:, i] = moved[:, i] - simulate_lti(model.phi, model.gamma[:, :2], model.c,
                                                 np.array([model.d, 0.0]),
                                                 axis_inputs(moved[:, i]))
    return error


def hold_samples(models: list[AxisModel], pieces: list[Reference], band: float,
                 every: int = 1) -> list[int]:
    """Samples [count] to hold the reference at the end of each piece (at the sampling
    period, all pieces sampled at it) until every axis' following error stays within
    ``band`` [m]; a multiple of ``every`` (the interpolation period in samples).

    Raises
    ------
    ValueError
        An axis that does not settle within ``band`` in :data:`MAX_SAMPLES` samples.
    UnstableAxis
        An unstable axis.
    """
    tail = run_out_samples(models, MAX_SAMPLES)
    total = np.zeros((0, len(models)))
    holds, start = [], 0
    for piece in pieces:
        error = piece_error(models, piece, tail)
        end = start + len(error)
        if end > len(total):
            total = np.vstack([total, np.zeros((max(end, 2 * len(total)) - len(total),
                                                len(models)))])
        total[start:end] += error
        arrival = start + len(piece.time) - 1
        outside = np.flatnonzero(np.any(np.abs(total[arrival:end]) > band, axis=1))
        hold = 0 if outside.size == 0 else int(outside[-1]) + 1
        if hold >= end - arrival:
            raise ValueError(f"the axes do not settle within the in-position band {band:g} m "
                             f"in {tail} samples")
        hold = every * math.ceil(hold / every)
        holds.append(hold)
        start = arrival + hold
    return holds


def settled_reference(models: list[AxisModel], path: Path, *, band: float, ratio: int = 1,
                      **interpolator) -> Reference:
    """The interpolator's reference with an in-position wait at every stop.

    Parameters
    ----------
    models : list of AxisModel
        The axes' closed loops at the sampling period (x, y[, z] in order).
    path : Path
    band : float
        In-position band [m]: every axis' following error within it, and staying there.
    ratio : int
        Interpolation period / sampling period [count]; the holds are whole interpolation
        periods.
    **interpolator
        :func:`~feedtune.machine.interpolate.stop_pieces`' keywords (``period`` the
        interpolation period [s]).

    Returns
    -------
    Reference
        At the interpolation period; ``summary["in_position"]`` lists each stop's hold [s].
    """
    pieces = stop_pieces(path, **interpolator)
    holds = hold_samples(models, [piece.resampled(ratio) for piece in pieces], band, ratio)
    return join(path, pieces, [hold // ratio for hold in holds])
