"""Figures of a simulated machine program: the programmed and actual path with the
contour error magnified and coloured, and the contour error against path length.

Drawn from a :class:`~feedtune.machine.run.MachineRun`'s arrays alone (the report imports
nothing of the tuner side, tests/architecture)."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def write_machine_report(result, directory: Path, magnify: float | None = None) -> list[Path]:
    """Draw ``path.png`` (the deviation across the path magnified, coloured by the contour
    error) and ``contour_error.png`` of a
    :class:`~feedtune.machine.run.MachineRun` into ``directory`` (created if missing).

    Parameters
    ----------
    magnify : float, optional
        Factor on the tool's deviation from the commanded point [1]; default: the largest
        deviation drawn as 5 % of the path's extent.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection

    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    error = result.contour_error
    deviation = result.actual - result.commanded
    tangent = result.tangent
    # the part of the deviation across the path (the contour error to first order); the
    # lag along the path is not magnified
    deviation = deviation - np.einsum("ij,ij->i", deviation, tangent)[:, None] * tangent
    extent = float(np.ptp(result.commanded[:, :2], axis=0).max()) or 1.0
    largest = float(np.max(np.linalg.norm(deviation[:, :2], axis=1))) or 1.0
    factor = magnify or 0.05 * extent / largest
    drawn = result.commanded[:, :2] + factor * deviation[:, :2]

    fig, ax = plt.subplots(figsize=(7, 6))
    ax.plot(result.commanded[:, 0] * 1e3, result.commanded[:, 1] * 1e3, color="0.6", lw=1,
            label="programmed")
    pts = drawn * 1e3
    segments = np.stack([pts[:-1], pts[1:]], axis=1)
    lines = LineCollection(segments, array=error[:-1] * 1e6, cmap="viridis", lw=2)
    ax.add_collection(lines)
    fig.colorbar(lines, ax=ax, label="contour error [µm]")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_title(f"actual path, deviation × {factor:.3g}")
    ax.legend(loc="best")
    first = directory / "path.png"
    fig.savefig(first, dpi=120, bbox_inches="tight")
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(8, 3.5))
    ax.plot(result.arc_length * 1e3, error * 1e6, lw=1)
    ax.set_xlabel("commanded path length [mm]")
    ax.set_ylabel("contour error [µm]")
    ax.grid(True, alpha=0.3)
    second = directory / "contour_error.png"
    fig.savefig(second, dpi=120, bbox_inches="tight")
    plt.close(fig)
    return [first, second]
