"""What a validator model of one plant offers: re-measured metrics for the ``validation``
block, and the curves ``feedtune report`` draws.

A model is built from a result's plant spec and tuned values (plain floats) by the class
registered for the plant type in :mod:`feedtune.validate.models`. It is written from the
papers with numpy/scipy, never from :mod:`feedtune.loops.loop` or CasADi (tests/architecture).
A method a plant cannot offer raises :class:`NotCovered` with the reason.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np


class NotCovered(ValueError):
    """The plant, option or quantity is outside what the validator models."""


@dataclass(frozen=True)
class Response:
    """A time response on a dense grid.

    ``kind``: ``step`` (unit position step), ``ramp`` (unit-velocity ramp) or ``load``
    (unit load-torque step, reference zero); ``time`` [s]; ``reference`` and ``position``
    in the axis' position unit (per N·m for ``load``); ``unit`` names it ("m", "rad",
    "rad/(N·m)").
    """

    kind: str
    time: np.ndarray
    reference: np.ndarray
    position: np.ndarray
    unit: str

    @property
    def error(self) -> np.ndarray:
        """reference − position, same unit."""
        return self.reference - self.position


@dataclass(frozen=True)
class CircleTrace:
    """The two-axis circle test: commanded radius ``radius`` [m] at ``feed`` [m/s], the
    steady path's radial deviation ``deviation`` [m] (actual radius − commanded) against
    the polar ``angle`` [rad] over one revolution."""

    radius: float
    feed: float
    angle: np.ndarray
    deviation: np.ndarray


class Model(Protocol):
    """A plant's independent model with tuned numbers."""

    #: True: poles are z-plane and frequency responses are of the sampled loop
    sampled: bool
    #: sampling period [s] when sampled, else None
    period: float | None
    #: unit of the axis position: "m" or "rad"
    position_unit: str

    def measure(self, result: dict) -> list[dict]:
        """Entries (see :func:`feedtune.validate.entries.entry`) for the metrics of
        ``result`` this model re-measures; poles and stability are added by the caller."""

    def poles(self) -> np.ndarray:
        """Closed-loop poles [1/s] (s-plane) or [1] (z-plane)."""

    def stable(self) -> bool:
        """Whether every closed-loop pole is inside the stability region."""

    def frequency_response(self, omega: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(L, H): open loop and closed loop (position/reference) at ``omega`` [rad/s]."""

    def responses(self) -> dict[str, Response]:
        """The step, ramp and (where the plant has a load input) load-torque responses."""

    def circle_test(self, radius: float, feed: float) -> CircleTrace:
        """The steady two-axis circle test at ``radius`` [m] and ``feed`` [m/s]."""
