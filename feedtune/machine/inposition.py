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
Bhatia's drive crosses null 14 ms after the stop, still moving, on its way to a 60 µm
overshoot; a control approximates this by checking the band and zero speed.)

How, without anything flowing back into a loop: every axis is linear and time-invariant,
so its following error over the program is the sum of the errors of the pieces of motion
between stops, each from rest and held at its end for the axes' run-out (until the slowest
mode has decayed by 1e-9, :func:`~feedtune.machine.simulate.run_out_samples`), shifted to
where the piece starts. All pieces' errors come from one simulation per axis of the pieces
end to end, each held for that run-out (the axes are then at rest to 1e-9 of the lag, and
the next piece starts as if from rest). Piece p starts where the hold of stop p − 1 ends, which
only the pieces before it decide: the holds are found one stop after another by adding
each piece's error into the running sum and reading where it leaves the band for the
last time. The result is a reference (:func:`~feedtune.machine.interpolate.join`) that
the machine simulation runs like any other: the axes never see anything but a reference.
The cost is one extra simulation of the pieces, each with its run-out
(benchmarks/machine_inposition.py).

Independent axes only: a cross-coupled controller's loop follows the path's direction,
so it is not time-invariant and the sum does not hold (the machine spec refuses both).
"""

from __future__ import annotations

import math

import numpy as np

from feedtune.machine.interpolate import MAX_SAMPLES, join, stop_pieces
from feedtune.machine.path import Path, Reference
from feedtune.machine.simulate import AxisModel, run_out_samples, simulate_independent


def piece_errors(models: list[AxisModel], pieces: list[Reference], tail: int) -> list[np.ndarray]:
    """Following error [m] (len(piece) + ``tail``, axes) of each piece, the axes starting
    at rest at its first point and the reference held at its last for ``tail`` samples.

    One simulation per axis: the pieces end to end, each held for ``tail`` samples (after
    which the axes are at rest at its end to within the run-out's decay, so the next
    piece starts as if from rest there)."""
    count = len(models)
    rows = np.concatenate([np.append(np.arange(len(piece.time)),
                                     np.full(tail, len(piece.time) - 1)) for piece in pieces])
    which = np.repeat(np.arange(len(pieces)), [len(piece.time) + tail for piece in pieces])
    command = np.concatenate([piece.position[:, :count] for piece in pieces])
    offsets = np.concatenate([[0], np.cumsum([len(piece.time) for piece in pieces])[:-1]])
    command = command[offsets[which] + rows]
    error = command - simulate_independent(models, command)
    return np.split(error, np.cumsum([len(piece.time) + tail for piece in pieces])[:-1])


def hold_samples(models: list[AxisModel], pieces: list[Reference], band: float,
                 every: int = 1) -> list[int]:
    """Samples [count] to hold the reference at the end of each piece (at the sampling
    period, all pieces sampled at it) until every axis' following error stays within
    ``band`` [m]; a multiple of ``every`` (the interpolation period in samples).

    Raises
    ------
    ValueError
        An axis that does not settle within ``band`` in its run-out.
    UnstableAxis
        An unstable axis.
    """
    tail = run_out_samples(models, MAX_SAMPLES)
    if sum(len(piece.time) + tail for piece in pieces) > MAX_SAMPLES:
        raise ValueError(f"{len(pieces)} stops, each with a run-out of {tail} samples: more "
                         f"than {MAX_SAMPLES} samples to find the in-position waits")
    total = np.zeros((0, len(models)))
    holds, start = [], 0
    for piece, error in zip(pieces, piece_errors(models, pieces, tail)):
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
