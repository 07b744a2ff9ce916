"""Koren's software servo: a first-order velocity drive in a position loop (Koren 1979).

``reference_pulse``: the up-down counter closes the loop continuously, open loop
K/(s(1 + sτ)) (eqs 3–7). ``sampled_data``: the computer samples the position every T,
and the error, times K, drives the motor through a DAC (zero-order hold), optionally
``computation_delay`` samples late (Fig 4, eqs 12–19).

References
----------
Y. Koren, "Design of Computer Control for Manufacturing Systems", ASME J. Eng. Ind.
101(3), 1979, pp. 326–332.
"""

from __future__ import annotations

import math
from typing import Literal, Mapping

import casadi as ca
import numpy as np
from pydantic import Field, PositiveFloat, model_validator

from feedtune.loop import ContinuousLoop, Drive, IntegratorLag, SampledLoop
from feedtune.model import SpecModel
from feedtune.plants.base import Tunable

#: sampled step responses are summed sample by sample over this many times (2τ + dead time)
SETTLING_TIME_CONSTANTS = 20.0


class SoftwareServoParams(SpecModel):
    """Koren 1979, Figs 2 (reference pulse) and 4 (sampled data)."""

    type: Literal["software_servo"]
    technique: Literal["reference_pulse", "sampled_data"] = Field(
        description="reference_pulse: continuous loop K/(s(1+sτ)) (eqs 3–7); "
                    "sampled_data: position sampled every T through a zero-order hold (Fig 4)")
    time_constant: PositiveFloat = Field(
        description="Mechanical time constant τ of the loaded drive [s] (eq 3)")
    blu: PositiveFloat = Field(description="Basic length unit, one encoder pulse [m]")
    max_velocity: PositiveFloat = Field(
        description="Maximum axis velocity V_m [m/s]; f_m = V_m/BLU (eq 1)")
    counter_bits: int = Field(
        8, ge=2, le=64,
        description="Bits of the feedback counter read every sample, sign bit included "
                    "[bit]; Koren's is 8 (7 bits of count, 128 pulses per sample)")
    computation_delay: int = Field(
        0, ge=0, le=8,
        description="Delay between sampling and output, in whole sampling periods "
                    "[samples] (sampled_data only)")

    @model_validator(mode="after")
    def _delay_needs_sampling(self):
        if self.technique == "reference_pulse" and self.computation_delay:
            raise ValueError("computation_delay applies to technique 'sampled_data' only")
        return self


class SoftwareServo:
    """Plant ``software_servo``: builds the closed loop for given gain and period."""

    Params = SoftwareServoParams

    def __init__(self, params: SoftwareServoParams):
        self.params = params

    def tunables(self) -> dict[str, Tunable]:
        tunables = {
            "position_gain": Tunable("1/s", "Open-loop gain K = K_c K_m K_e (eq 5)", 0.1, 1000.0),
        }
        if self.params.technique == "sampled_data":
            tunables["sampling_period"] = Tunable(
                "s", "Sampling period T = 1/f_s (eqs 14–19)", 1e-3, 0.5)
        return tunables

    def drive(self) -> Drive:
        p = self.params
        return Drive(time_constant=p.time_constant, blu=p.blu, max_velocity=p.max_velocity,
                     counter_bits=p.counter_bits)

    def loop(self, values: Mapping[str, object], box: Mapping[str, tuple[float, float]],
             horizon_scale: float = 1.0):
        """The closed loop at ``values`` (expressions or numbers per tunable name).

        ``box`` gives each tunable's (min, max) [its unit]; with ``horizon_scale`` it sizes
        the step-response horizon of a sampled loop (20·(2τ + dead time)·horizon_scale),
        which the tuner lengthens when the NLP and the exact evaluation disagree.
        """
        p = self.params
        tau = p.time_constant
        gain = values["position_gain"]
        if p.technique == "reference_pulse":
            a = ca.MX.zeros(2, 2)
            a[0, 1] = 1
            a[1, 0] = -gain / tau
            a[1, 1] = -1 / tau
            b = ca.MX.zeros(2, 1)
            b[1, 0] = gain / tau
            return ContinuousLoop(a, b, ca.DM([[1, 0]]), gain, self.drive())
        period_min, period_max = box["sampling_period"]
        # loops near the optimum settle within tens of (2τ + dead time); slower, overdamped
        # loops are still exact through the closed-form tail of SampledLoop
        settle = 2 * tau + (p.computation_delay + 1) * period_max
        return SampledLoop(IntegratorLag(tau), gain, values["sampling_period"],
                           delay=p.computation_delay, drive=self.drive(),
                           horizon=SETTLING_TIME_CONSTANTS * settle * horizon_scale,
                           period_min=period_min)


def koren_step_response(gain: float, period: float, time_constant: float, samples: int):
    """Koren eqs 16–19: sampled step response W(n)/V and its constants.

    Returns ``(response, alpha_t, omega_t, m, zeta)`` for n = 0..samples−1, where
    W(n)/V = 1 − e^{−nαT}(cos nωT + M sin nωT). Valid for complex closed-loop poles and
    no computation delay. W(n) is the counter reading ΔP(n)/T, which equals the position
    step response at sample n (DESIGN.md errata).
    """
    k, t, tau = gain, period, time_constant
    x = math.exp(-t / tau)
    a = math.sqrt(x + k * (tau * (1 - x) - t * x))
    omega_t = math.acos((1 + x - k * t + k * tau * (1 - x)) / (2 * a))  # eq 18
    alpha_t = -math.log(a)  # eq 17
    m = ((1 - x) * (1 + k * tau) - k * t) / (2 * a * math.sin(omega_t))
    zeta = alpha_t / math.hypot(alpha_t, omega_t)  # eq 19
    n = np.arange(samples)
    response = 1 - np.exp(-n * alpha_t) * (np.cos(n * omega_t) + m * np.sin(n * omega_t))
    return response, alpha_t, omega_t, m, zeta
