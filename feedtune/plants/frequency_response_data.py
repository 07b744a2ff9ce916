"""Measured frequency responses of an axis, tuned without a model by the convex technique.

One or several sets of G(jω) from the drive's command to the position, with the
controller the data-driven design tunes.

The data are inline in the spec (a spec never names a file): each set gives its
frequencies with their unit (``rad/s`` or ``Hz``, declared) and the real and imaginary
parts of G(jω) [position unit per command unit]. ``feedtune identify DATA --model frd -o
PLANT.json`` writes this block from measured files
(:func:`feedtune.measured.datadriven_spec.frd_plant_block`). What the data cannot say is
declared: the plant's poles at s = 0 (``integrators``) and in the right half-plane
(``unstable_poles``), which the Nyquist certificate counts against.

The controller is linear in its parameters over a fixed denominator, K(s) = k_p + k_i/s +
k_d s/(τ_f s + 1) (P, PI, PD or PID; τ_f fixed), which is what makes the design convex
(:mod:`feedtune.measured.datadriven`). Such a plant is tuned by the ``convex`` technique,
not the NLP: it has no model to build a Loop from.

References
----------
A. Karimi, C. Kammer, "A data-driven approach to robust control of multivariable systems
by convex optimization", Automatica 85 (2017) 227–233 (frequency-response data of several
operating conditions, a controller linear in its parameters).
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, NonNegativeInt, PositiveFloat, field_validator, model_validator

from feedtune.measured.data import FREQUENCY_UNITS, MIN_POINTS
from feedtune.measured.datadriven import ControllerBasis, FrequencySet
from feedtune.plants.base import Plant, Tunable
from feedtune.schema.model import SpecModel

#: work limits of an untrusted spec: sets, and points per set (a spec is ≤ 1 MB anyway)
MAX_SETS = 16
MAX_POINTS = 20_000

#: default bounds of the controller's gains; narrow them in the spec
GAIN_BOUNDS = (1e-6, 1e6)


class FrequencySetSpec(SpecModel):
    """One measured frequency response G(jω), command → position."""

    name: str = Field(min_length=1, max_length=64,
                      description="What the set is, e.g. a table position or a load [text]")
    frequency_unit: Literal["rad/s", "Hz"] = Field(
        description="Unit of ``frequency``: rad/s or Hz (declared, never guessed)")
    frequency: list[PositiveFloat] = Field(
        min_length=MIN_POINTS, max_length=MAX_POINTS,
        description=f"Measured frequencies, strictly increasing [frequency_unit]; at least "
                    f"{MIN_POINTS}")
    real: list[float] = Field(min_length=MIN_POINTS, max_length=MAX_POINTS,
                              description="Re G(jω) at each frequency [position unit per "
                                          "command unit, e.g. m/V]")
    imag: list[float] = Field(min_length=MIN_POINTS, max_length=MAX_POINTS,
                              description="Im G(jω) at each frequency [position unit per "
                                          "command unit]")

    @field_validator("frequency")
    @classmethod
    def _increasing(cls, frequency: list[float]) -> list[float]:
        for i in range(1, len(frequency)):
            if not frequency[i] > frequency[i - 1]:
                raise ValueError(f"frequencies must increase strictly: item {i} "
                                 f"({frequency[i]}) follows {frequency[i - 1]}")
        return frequency

    @model_validator(mode="after")
    def _same_length(self):
        for name in ("real", "imag"):
            if len(getattr(self, name)) != len(self.frequency):
                raise ValueError(f"'{name}' has {len(getattr(self, name))} values for "
                                 f"{len(self.frequency)} frequencies")
        if all(r == 0.0 and i == 0.0 for r, i in zip(self.real, self.imag)):
            raise ValueError("G(jω) is zero at every frequency")
        return self

    def as_set(self) -> FrequencySet:
        """The set in rad/s, G complex (:class:`~feedtune.measured.datadriven.FrequencySet`)."""
        import numpy as np

        scale = FREQUENCY_UNITS[self.frequency_unit]
        return FrequencySet(self.name, np.asarray(self.frequency, dtype=float) * scale,
                            np.asarray(self.real, dtype=float) + 1j * np.asarray(self.imag, dtype=float))


class FrequencyResponseDataParams(SpecModel):
    """Measured frequency responses (Karimi & Kammer 2017), tuned without a model."""

    type: Literal["frequency_response_data"]
    input_unit: str = Field("V", min_length=1, max_length=32,
                            description="Unit of the drive's command, e.g. V, A, N·m [text]")
    output_unit: Literal["m", "rad"] = Field(
        "m", description="Unit of the measured position: m (linear axis) or rad (rotary)")
    sets: list[FrequencySetSpec] = Field(
        min_length=1, max_length=MAX_SETS,
        description="The measured frequency responses of the axis, e.g. at several table "
                    f"positions or loads; every bound holds on every set [at most {MAX_SETS}]")
    integrators: NonNegativeInt = Field(
        1, le=3, description="Poles of the plant at s = 0 [count]: 1 for a position measured "
                             "behind a velocity-controlled drive; the Nyquist certificate "
                             "counts them")
    unstable_poles: NonNegativeInt = Field(
        0, le=4, description="Poles of the plant in the open right half-plane [count] "
                             "(0 for a feed drive); the Nyquist certificate counts them")
    controller: Literal["p", "pi", "pd", "pid"] = Field(
        "pid", description="K(s) = k_p (p), + k_i/s (pi), + k_d s/(τ_f s + 1) (pd, pid)")
    filter_time_constant: PositiveFloat | None = Field(
        None, description="τ_f of the derivative's filter [s], fixed (pd, pid): the design "
                          "is convex because K's denominator is")

    @model_validator(mode="after")
    def _filter_given(self):
        if "d" in self.controller and self.filter_time_constant is None:
            raise ValueError(f"controller {self.controller!r} needs filter_time_constant [s]")
        if "d" not in self.controller and self.filter_time_constant is not None:
            raise ValueError(f"controller {self.controller!r} has no derivative: leave out "
                             "filter_time_constant")
        names = [s.name for s in self.sets]
        repeated = sorted({n for n in names if names.count(n) > 1})
        if repeated:
            raise ValueError(f"set names must differ: {', '.join(repeated)} repeated")
        return self


class FrequencyResponseData(Plant):
    """Plant ``frequency_response_data``: measured G(jω), tuned by the ``convex`` technique."""

    Params = FrequencyResponseDataParams
    technique = "convex"

    def __init__(self, params: FrequencyResponseDataParams):
        self.params = params

    @property
    def position_unit(self) -> str:
        return self.params.output_unit

    def basis(self) -> ControllerBasis:
        """The controller's parameters φ(s) (:class:`~feedtune.measured.datadriven.ControllerBasis`)."""
        return ControllerBasis(self.params.controller, self.params.filter_time_constant)

    def sets(self) -> list[FrequencySet]:
        """Every measured set in rad/s."""
        return [s.as_set() for s in self.params.sets]

    def tunables(self) -> dict[str, Tunable]:
        """``controller.kp`` [U/x], ``controller.ki`` [U/(x·s)], ``controller.kd`` [U·s/x] for
        command unit U and position unit x."""
        u, x = self.params.input_unit, self.params.output_unit
        described = {
            "kp": Tunable(f"{u}/{x}", f"Proportional gain k_p [{u}/{x}]", *GAIN_BOUNDS),
            "ki": Tunable(f"{u}/({x}·s)", f"Integral gain k_i: k_i/s [{u}/({x}·s)]", *GAIN_BOUNDS),
            "kd": Tunable(f"{u}·s/{x}", f"Derivative gain k_d: k_d s/(τ_f s + 1) [{u}·s/{x}]",
                          *GAIN_BOUNDS),
        }
        return {f"controller.{name}": described[name] for name in self.basis().names}
