"""Reference-pulse generator: Tian's V-F transformation with acceleration limit.

A numerical controller that drives a stepper or pulse-train servo: every period T = 1/f it
compares the command with its pulse counter, limits the error to ±``error_limit``
(Tian's ``value``), optionally limits the error's change per period to value/k (the
acceleration law, Tian eq 2), and accumulates it, sending one ± pulse of δ (the pulse
equivalent) each time the sum passes ±value (Tian §2, Fig 2). At most one pulse leaves per
period, so the pulse rate is at most f and the velocity at most v_max = δ f (Koren 1979 eq
1, f_m = V_m/BLU, with the iteration rate of eq 2 as the pulse-rate ceiling). Without the
law the commanded acceleration reaches δ f² (Tian eq 1); with it δ f²/k.

The loop is :class:`feedtune.loops.pulse_train.PulseLoop`: an exact, discrete simulation, not a
linear model. Its tunables are tuned by the derivative-free search of
:mod:`feedtune.tuner.search` (see docs/tian.md).

References
----------
J. Tian, Y. Kamiya, H. Seki, M. Hikizu, "A New Method of Generating Pulse Series for
Numerical Controller" (Kanazawa University), §2–§4, eqs 1–2, Figs 1–5.
Y. Koren, "Design of Computer Control for Manufacturing Systems", ASME J. Eng. Ind.
101(3), 1979, Reference-Pulse technique, eqs 1–2.
"""

from __future__ import annotations

from typing import Annotated, Literal, Mapping

from pydantic import Field, NonNegativeFloat, PositiveFloat, model_validator

from feedtune.loops.pulse_train import MotorCharacteristic, PulseInput, PulseLoop
from feedtune.plants.base import Plant, Tunable
from feedtune.schema.model import SpecModel


class PulseGeneratorParams(SpecModel):
    """Tian et al. §2–§4: the V-F transformation, error limit and acceleration law."""

    type: Literal["pulse_generator"]
    pulse_equivalent: PositiveFloat | None = Field(
        None, description="Pulse equivalent δ: travel per pulse [rad or m per pulse] (Tian "
                          "eq 1, Koren's BLU); give this or max_velocity")
    max_velocity: PositiveFloat | None = Field(
        None, description="Velocity at one pulse per period, v_max = δ·f [rad/s or m/s] (Tian "
                          "§4: 430 rad/s at 140 kHz); with it δ = max_velocity/sampling_frequency "
                          "follows the tuned frequency; give this or pulse_equivalent")
    position_unit: Literal["rad", "m"] = Field(
        "rad", description="Unit of every position [rad for a rotary axis, m for a linear one]")
    acceleration_law: bool = Field(
        True, description="Apply Tian's acceleration law |e_i − e_(i−1)| ≤ value/k (eq 2) "
                          "[true/false]; false: the acceleration reaches δ·f² (eq 1)")
    motor_characteristic: list[Annotated[list[NonNegativeFloat], Field(min_length=2, max_length=2)]] | None = Field(
        None, min_length=1,
        description="The motor's torque–frequency characteristic as [pulse rate "
                    "[pulses/s], maximum acceleration [rad/s² or m/s²]] rows, linear in "
                    "between; above the last rate the motor cannot follow. Needed by the "
                    "motor_acceleration_margin metric")
    input: Literal["step", "ramp", "sine"] = Field(
        "step", description="Command: step of amplitude at t = 0; ramp at ramp_velocity from "
                            "t = 0; sine amplitude·sin(sine_frequency·t)")
    amplitude: float = Field(
        1.0, description="Step size or sine amplitude [rad or m] (Tian §4: 10 rad)")
    ramp_velocity: float = Field(
        1.0, description="Velocity of the ramp command [rad/s or m/s] (input ramp)")
    sine_frequency: PositiveFloat = Field(
        10.0, description="Angular frequency ω of the sine command [rad/s] (input sine)")
    sine_cycles: PositiveFloat = Field(
        2.0, description="Sine periods simulated when duration is omitted [1]; the tracking "
                         "error is measured over the last one")
    duration: PositiveFloat | None = Field(
        None, description="Simulated time [s]; omitted: long enough for a step to come to "
                          "rest (3× the travel, ramp and 20 loop time constants), or "
                          "sine_cycles periods of a sine")

    @model_validator(mode="after")
    def _one_scale(self):
        if (self.pulse_equivalent is None) == (self.max_velocity is None):
            raise ValueError("give exactly one of pulse_equivalent and max_velocity")
        if self.motor_characteristic is not None:
            rates = [r for r, _ in self.motor_characteristic]
            if len(set(rates)) != len(rates):
                raise ValueError("motor_characteristic: pulse rates must be distinct")
            if any(a <= 0 for _, a in self.motor_characteristic):
                raise ValueError("motor_characteristic: maximum accelerations must be positive")
        return self


class PulseGenerator(Plant):
    """Tian's reference-pulse generator with error limit and acceleration law."""

    Params = PulseGeneratorParams

    def __init__(self, params: PulseGeneratorParams):
        self.params = params

    @property
    def position_unit(self) -> str:
        return self.params.position_unit

    def tunables(self) -> dict[str, Tunable]:
        u = self.params.position_unit
        tunables = {
            "error_limit": Tunable(
                u, "Tian's value: error limit and V-F threshold; one pulse per period at "
                   "e = value, so the position-loop gain is v_max/value", 1e-4, 100.0),
            "sampling_frequency": Tunable(
                "Hz", "Sampling frequency f = maximum pulse rate [pulses/s] (Tian §3, "
                      "Koren eq 2)", 1e3, 1e6),
        }
        if self.params.acceleration_law:
            tunables["acceleration_ratio"] = Tunable(
                "1", "Tian's k: controller acceleration δf² over the allowed one; the law "
                     "|e_i − e_(i−1)| ≤ value/k limits the acceleration to δf²/k (eq 2)",
                1.0, 1e5)
        return tunables

    def numbers(self) -> dict[str, float]:
        """The number the simulation reads as given (in its unit): the pulse equivalent δ
        [rad or m per pulse], or v_max [rad/s or m/s] when δ follows the frequency.
        :meth:`loop` also takes it in ``values`` (a robust scenario's value)."""
        p = self.params
        if p.pulse_equivalent is not None:
            return {"pulse_equivalent": p.pulse_equivalent}
        return {"max_velocity": p.max_velocity}

    def not_uncertain(self) -> dict[str, str]:
        """Why the command and the motor's table cannot be uncertain."""
        command = ("it describes the command, not the drive: the step, ramp or sine and "
                   "its length set the simulated horizon; tune one spec per command")
        return {**{name: command for name in ("amplitude", "ramp_velocity", "sine_frequency",
                                              "sine_cycles", "duration")},
                "motor_characteristic": "the motor's torque-frequency table is a piecewise "
                                        "linear curve read by the margin metric, not a "
                                        "number of the simulation; give one spec per motor"}

    def loop(self, values: Mapping[str, object], box: Mapping[str, tuple[float, float]] | None = None,
             horizon_scale: float = 1.0) -> PulseLoop:
        """The controller at ``values`` (numbers; symbols give a loop whose response raises).

        ``horizon_scale`` lengthens the automatic horizon (the tuner asks for it when a
        response did not come to rest).
        """
        p = self.params
        frequency = values["sampling_frequency"]
        n = {**self.numbers(), **{name: values[name] for name in self.numbers() if name in values}}
        delta = n["pulse_equivalent"] if "pulse_equivalent" in n else n["max_velocity"] / frequency
        command = PulseInput(p.input, amplitude=p.amplitude, velocity=p.ramp_velocity,
                             angular_frequency=p.sine_frequency)
        motor = (MotorCharacteristic.from_table(p.motor_characteristic)
                 if p.motor_characteristic is not None else None)
        return PulseLoop(pulse_equivalent=delta, frequency=frequency,
                         error_limit=values["error_limit"],
                         acceleration_ratio=values["acceleration_ratio"] if p.acceleration_law else None,
                         command=command, duration=p.duration, motor=motor,
                         position_unit=p.position_unit, cycles=p.sine_cycles,
                         horizon_scale=horizon_scale)
