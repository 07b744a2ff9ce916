"""Software servo: a velocity drive in a position loop (Koren 1979; Sato et al.).

``reference_pulse``: the up-down counter closes the loop continuously, open loop
K/(s(1 + sτ)) (Koren eqs 3–7). ``sampled_data``: the computer samples the position every
T (Sato's Δt_p), and the error, times K, drives the motor through a DAC (zero-order hold),
optionally ``computation_delay`` samples late (Koren Fig 4, eqs 12–19). Without a time
constant the drive is ideal, 1/s: Sato's software servo is that drive with one sample of
computation delay (Fig 1, total dead time L = 1.5 Δt_p).

``model``: ``exact`` discretises the sampled loop exactly; ``pade`` is Sato's continuous
approximation, the dead time L = (computation_delay + ½)·T in the loop replaced by its
(1,1) Padé approximant (1 − Ls/2)/(1 + Ls/2) (Sato eqs 4–5).

``interpolation``: ``linear`` puts an interpolator in front of the servo that sends a
point on the path every reference interval (Sato Figs 2–3); the loop then carries an
:class:`~feedtune.loops.loop.Interpolator` for the circle metrics of Sato et al.
``integer_ratio`` asks the tuner (``feedtune.problem``) for a whole q = T/Δt_p.

References
----------
Y. Koren, "Design of Computer Control for Manufacturing Systems", ASME J. Eng. Ind.
101(3), 1979, pp. 326–332.
S. Sato, M. Nakamura, S. Goto, N. Egashira, N. Kyura, "Decision Method of Reference
Input Time Interval and Sampling Time Interval that Considered Contour Control
Performance in Software Servo System", eqs 1–10, Figs 1–3.
"""

from __future__ import annotations

import json
import math
from typing import Literal, Mapping

from pydantic import Field, PositiveFloat, model_validator

from feedtune.lazy import Deferred, ca, np
from feedtune.loops import linalg
from feedtune.loops.loop import (ContinuousLoop, Drive, Integrator, IntegratorLag, Interpolator,
                                 SampledLoop, TransferLoop)
from feedtune.loops.protocols import DeclaredCapabilities
from feedtune.plants.base import NYQUIST_MARGIN, SETTLING_TIME_CONSTANTS, Plant, Tunable
from feedtune.schema.model import SpecModel


class SoftwareServoParams(SpecModel):
    """Koren 1979, Figs 2 (reference pulse) and 4 (sampled data); Sato et al., Fig 1."""

    type: Literal["software_servo"]
    technique: Literal["reference_pulse", "sampled_data"] = Field(
        description="reference_pulse: continuous loop K/(s(1+sτ)) (eqs 3–7); "
                    "sampled_data: position sampled every T through a zero-order hold (Fig 4)")
    time_constant: PositiveFloat | None = Field(
        description="Mechanical time constant τ of the loaded drive [s] (Koren eq 3); null: an "
                    "ideal velocity drive, position the integral of the command (Sato Fig 1; "
                    "sampled_data only)")
    blu: PositiveFloat | None = Field(
        None, description="Basic length unit, one encoder pulse [m]; omitted: the metrics that "
                          "need it (min_radius, encoder_ratio, ...) are not available")
    max_velocity: PositiveFloat | None = Field(
        None, description="Maximum axis velocity V_m [m/s]; f_m = V_m/BLU (eq 1); omitted: as blu")
    counter_bits: int = Field(
        8, ge=2, le=64,
        description="Bits of the feedback counter read every sample, sign bit included "
                    "[bit]; Koren's is 8 (7 bits of count, 128 pulses per sample)")
    computation_delay: int = Field(
        0, ge=0, le=8,
        description="Delay between sampling and output, in whole sampling periods "
                    "[samples] (sampled_data only; Sato's servo has 1)")
    model: Literal["exact", "pade"] = Field(
        "exact",
        description="exact: the sampled loop discretised exactly; pade: Sato's approximation, "
                    "the dead time L = (computation_delay + 1/2)·sampling_period [s] as its "
                    "(1,1) Padé approximant in a continuous loop (Sato eqs 4–5) "
                    "(sampled_data only)")
    interpolation: Literal["none", "linear"] = Field(
        "none",
        description="none: the servo reads the path itself every sample (Koren's circle of "
                    "sinusoids); linear: an interpolator sends a point on the path every "
                    "reference_interval [s], the servo steps along each chord (Sato Figs 2–3); "
                    "adds the tunable reference_interval (sampled_data only)")
    integer_ratio: bool = Field(
        False,
        description="q = reference_interval/sampling_period must be a whole number [1]: the "
                    "tuner solves with q continuous, then again with q fixed at the whole "
                    "numbers below and above (a constraint interpolation_ratio min = max) and "
                    "keeps the better feasible result (interpolation linear only)")

    @model_validator(mode="after")
    def _sampling_options_need_sampling(self):
        if self.technique == "reference_pulse":
            sampled_only = {"computation_delay": self.computation_delay != 0,
                            "time_constant": self.time_constant is None,
                            "model": self.model != "exact",
                            "interpolation": self.interpolation != "none"}
            for name, given in sampled_only.items():
                if given:
                    raise ValueError(f"{name} = {json.dumps(getattr(self, name))} applies to "
                                     "technique 'sampled_data' only")
        if self.integer_ratio and self.interpolation != "linear":
            raise ValueError("integer_ratio = true applies to interpolation 'linear' only")
        return self


class SoftwareServo(Plant):
    """Plant ``software_servo``: builds the closed loop for given gain and period."""

    Params = SoftwareServoParams
    position_unit = "m"  # a linear axis: table position

    def __init__(self, params: SoftwareServoParams):
        self.params = params

    def tunables(self) -> dict[str, Tunable]:
        tunables = {
            "position_gain": Tunable("1/s", "Open-loop gain K = K_c K_m K_e (eq 5)", 0.1, 1000.0),
        }
        if self.params.technique == "sampled_data":
            tunables["sampling_period"] = Tunable(
                "s", "Sampling period T = 1/f_s (Koren eqs 14–19), Sato's Δt_p", 1e-3, 0.5)
            if self.params.interpolation == "linear":
                tunables["reference_interval"] = Tunable(
                    "s", "Reference input interval T of the linear interpolator, one point on "
                         "the path every T: N = 2π/(ωT) sides per circle, q = T/Δt_p steps "
                         "per side (Sato eq 1; interpolation linear only)", 1e-3, 1.0)
        return tunables

    def numbers(self) -> dict[str, float]:
        """The parameters :meth:`loop` also takes in ``values`` (as expressions: NLP
        parameters): they enter the loop only through arithmetic. The horizon, the
        frequency band and every choice still read the spec's own numbers
        (:meth:`structure`)."""
        p = self.params
        given = {"time_constant": p.time_constant, "blu": p.blu, "max_velocity": p.max_velocity}
        return {name: value for name, value in given.items() if value is not None}

    def structure(self, box: Mapping[str, tuple[float, float]],
                  horizon_scale: float = 1.0) -> str:
        """The choices and the numbers the loop's graph embeds (see
        :meth:`feedtune.plants.base.Plant.structure`): the reference-pulse loop none;
        Padé's loop its band [rad/s]; the sampled loop's are :meth:`embedded_numbers`."""
        p = self.params
        choices = p.model_dump(mode="json", exclude=set(self.numbers()))
        choices["ideal_drive"] = p.time_constant is None
        embedded: list = []
        if p.technique == "sampled_data" and p.model == "pade":
            embedded = list(self._pade_band(box))
        return json.dumps([choices, embedded], sort_keys=True)

    def embedded_numbers(self, box: Mapping[str, tuple[float, float]],
                         horizon_scale: float = 1.0) -> dict[str, object]:
        """The sampled (ZOH) loop's step-response ``horizon`` [s], the smallest period
        ``period_min`` [s] it is summed in and its ``frequency_band`` [rad/s], by the
        :class:`~feedtune.loops.loop.SampledLoop` attributes that hold them (which records
        the ones its graph reads: a loop without step integrals or frequency metrics reads
        none, and then shares its structure with every τ and period box); the
        reference-pulse loop's ``frequency_band`` [rad/s]; none for Padé's loop, whose
        band is in :meth:`structure` (see :meth:`feedtune.plants.base.Plant.embedded_numbers`)."""
        p = self.params
        if p.technique == "reference_pulse":
            return {"frequency_band": list(self._pulse_band(box))}
        if p.model == "pade":
            return {}
        period_min = box["sampling_period"][0]
        return {"horizon": self._horizon(period_min, horizon_scale), "period_min": period_min,
                "frequency_band": list(self._sampled_band(box))}

    def _horizon(self, period_min: float, horizon_scale: float) -> float:
        """The sampled step responses' horizon [s]: SETTLING_TIME_CONSTANTS·(2τ + dead time
        at T_min)·horizon_scale."""
        p = self.params
        settle = 2 * (p.time_constant or 0.0) + (p.computation_delay + 1) * period_min
        return SETTLING_TIME_CONSTANTS * settle * horizon_scale

    def drive(self, numbers: Mapping[str, object] | None = None) -> Drive:
        """The drive of the spec's numbers, each of ``numbers`` (name → number or expression)
        in its place."""
        p = self.params
        n = {**self.numbers(), **(numbers or {})}
        return Drive(time_constant=n.get("time_constant"), blu=n.get("blu"),
                     max_velocity=n.get("max_velocity"), counter_bits=p.counter_bits)

    def loop(self, values: Mapping[str, object], box: Mapping[str, tuple[float, float]],
             horizon_scale: float = 1.0):
        """The closed loop at ``values`` (expressions or numbers per tunable name, and for
        any of :meth:`numbers`, which then replace the spec's own in the arithmetic).

        ``box`` gives each tunable's (min, max) [its unit]; with ``horizon_scale`` it sizes
        the step-response horizon of a sampled loop (20·(2τ + dead time at T_min)·
        horizon_scale, summed in steps of T_min: 20·(2τ/T_min + d + 1)·horizon_scale
        samples), which the tuner lengthens when the NLP and the exact evaluation disagree.
        """
        numbers = {name: values[name] for name in self.numbers() if name in values}
        p = self.params
        tau = {**self.numbers(), **numbers}.get("time_constant")  # in arithmetic
        drive = self.drive(numbers)
        gain = values["position_gain"]
        if p.technique == "reference_pulse":
            a = ca.MX.zeros(2, 2)
            a[0, 1] = 1
            a[1, 0] = -gain / tau
            a[1, 1] = -1 / tau
            b = ca.MX.zeros(2, 1)
            b[1, 0] = gain / tau
            return ContinuousLoop(a, b, ca.DM([[1, 0]]), gain, drive,
                                  open_loop=([gain], [tau, 1, 0]),
                                  frequency_band=self._pulse_band(box))
        period = values["sampling_period"]
        interpolator = None
        if p.interpolation == "linear":
            interpolator = Interpolator(values["reference_interval"], period)
        if p.model == "pade":
            return self._pade_loop(gain, period, box, interpolator, tau, drive)
        period_min = box["sampling_period"][0]
        # loops near the optimum settle within tens of (2τ + dead time); slower, overdamped
        # loops are still exact through the closed-form tail of SampledLoop (an ideal drive
        # has no step integrals, so its horizon is unused). The NLP sums a fixed number of
        # samples, 20·(2τ/T_min + d + 1): at any T ≥ T_min they span at least
        # 20·(2τ + (d + 1)·T), twenty of that loop's own (2τ + dead time). Sizing the time
        # by T_max instead summed T_max/T_min times longer than the fastest loop needs
        # (10 800 samples for T in [1 ms, 0.5 s]: a 40 s tuning)
        plant = IntegratorLag(tau) if tau is not None else Integrator()
        return SampledLoop(plant, gain, period, delay=p.computation_delay, drive=drive,
                           horizon=self._horizon(period_min, horizon_scale),
                           period_min=period_min, interpolator=interpolator,
                           frequency_band=self._sampled_band(box))

    def checked_loop(self, values: Mapping[str, float], box: Mapping[str, tuple[float, float]]):
        """The loop a spec's checks read (:meth:`feedtune.plants.base.Plant.checked_loop`):
        the reference-pulse loop, whose matrices are CasADi's, as a :class:`_PulseLoopFacts`
        that answers from the configuration what the checks ask of it (a second-order
        continuous loop, its drive, C_v = K, its frequency band) and builds :meth:`loop`
        for anything else (a metric evaluated at the box's corners); the sampled loops
        build no matrix until asked."""
        if self.params.technique != "reference_pulse":
            return self.loop(values, box)
        numbers = {name: values[name] for name in self.numbers() if name in values}
        return _PulseLoopFacts(lambda: self.loop(values, box),
                               capabilities=ContinuousLoop.capabilities, exact_only=False,
                               discrete=False, period=None, order=2, interpolator=None,
                               has_exact_step_error=True, drive=self.drive(numbers),
                               velocity_constant=values["position_gain"],
                               frequency_band=self._pulse_band(box))

    def _pulse_band(self, box) -> tuple[float, float]:
        """(low, high) [rad/s] of the reference-pulse loop's frequency metrics: its corners
        K and 1/τ over the box, two decades either side."""
        corners = [*box["position_gain"], 1 / self.params.time_constant]
        return min(corners) / 100, max(corners) * 100

    def _sampled_band(self, box) -> tuple[float, float]:
        """(low, high) [rad/s] of the sampled loop's frequency metrics: two decades below
        its corners over the box (K_min, 1/τ, π/T_max), up to NYQUIST_MARGIN above π/T_min
        so that the Nyquist frequency of every period in the box lies inside the band."""
        (k_min, _), (t_min, t_max) = box["position_gain"], box["sampling_period"]
        corners = [k_min, math.pi / t_max]
        if self.params.time_constant is not None:
            corners.append(1 / self.params.time_constant)
        return min(corners) / 100, math.pi / t_min * NYQUIST_MARGIN

    def _pade_loop(self, gain, period, box, interpolator, tau, drive) -> TransferLoop:
        """Sato eqs 4–5: open loop K·(1 − Ls/2)/((1 + Ls/2)·s·(1 + sτ)), L = (d + ½)·T.

        Without τ the closed loop is K(2/L − s)/(s² + (2/L − K)s + 2K/L), eq 5.
        """
        p = self.params
        half_dead_time = (p.computation_delay + 0.5) * period / 2  # L/2 [s]
        lag = [tau, 1] if tau is not None else [1]
        denominator = linalg.poly_mul(linalg.poly_mul([half_dead_time, 1], lag), [1, 0])
        return TransferLoop(open_numerator=[-gain * half_dead_time, gain],
                            open_denominator=denominator,
                            frequency_band=self._pade_band(box), drive=drive,
                            interpolator=interpolator)

    def _pade_band(self, box) -> tuple[float, float]:
        """(low, high) [rad/s] of Padé's loop: its corners K, 2/L and 1/τ over the box, two
        decades either side."""
        p = self.params
        (k_min, k_max), (t_min, t_max) = box["position_gain"], box["sampling_period"]
        corners = [k_min, k_max, 2 / ((p.computation_delay + 0.5) * t_max),
                   2 / ((p.computation_delay + 0.5) * t_min)]
        if p.time_constant is not None:
            corners.append(1 / p.time_constant)
        return min(corners) / 100, max(corners) * 100


class _PulseLoopFacts(Deferred):
    """Koren's reference-pulse :class:`~feedtune.loops.loop.ContinuousLoop` (A = [[0, 1],
    [−K/τ, −1/τ]], eq 5) as far as a spec's checks ask it: what is given (the built
    loop's own values, ``tests/unit/test_numeric_loop_queries.py``) and ``offers`` as that
    class answers it; any other member is the built loop's (CasADi imported then)."""

    offers = DeclaredCapabilities.offers


def koren_step_response(gain: float, period: float, time_constant: float, samples: int):
    """Koren eqs 16–19: sampled step response W(n)/V and its constants.

    Returns ``(response, alpha_t, omega_t, m, zeta)`` for n = 0..samples−1, where
    W(n)/V = 1 − e^{−nαT}(cos nωT + M sin nωT). Valid for complex closed-loop poles and
    no computation delay. W(n) is the counter reading ΔP(n)/T, which equals the position
    step response at sample n (docs/design.md errata).
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
