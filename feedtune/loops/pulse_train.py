"""Reference-pulse generation by Tian's V-F transformation: the exact pulse simulation.

A numerical controller samples the position command every period T = 1/f, compares it
with its own pulse counter (the counter times the pulse equivalent δ is the position, Tian
§2, Fig 1), and feeds the error e_i through

1. the **error limit**: e_i is clipped to ±``value`` (Tian: "the value of the error limit is
   supposed to be equal to the value given to the V-F transformer");
2. the **acceleration law** (optional): |e_i − e_{i−1}| ≤ value/k (Tian eq 2);
3. the **V-F transformer**: ``sum += e_i``; while sum ≥ value one + pulse is sent and
   ``sum −= value``; sum ≤ −value: one − pulse and ``sum += value`` (Tian §2, Fig 2).

Since |e_i| ≤ value, at most one pulse leaves per period: the pulse rate is at most f and
the velocity at most v_max = δ·f (Koren 1979 eq 1, f_m = V_m/BLU). The commanded pulse
rate is f·e_i/value, so the commanded velocity is v_i = δ f e_i/value, and its change per
period, times f, is the commanded acceleration; without the law e_i may jump from 0 to
value in one period, a_max = δ f² (Tian eq 1); with it |a_i| ≤ δ f²/k.

Units. ``value`` and e_i are positions [rad or m], as in Tian: "the compared error between
expected position and actual position". The controller compares whole pulses: the command
is rounded to the nearest pulse (δ) each period, the counter is an integer, so a step
comes to rest exactly (e = 0, no more pulses), and internally everything is in pulses
(value/δ, the reference and the counter). The simulation is the algorithm itself,
period by period, in float64: no model, no smoothing. Its metrics are piecewise constant
in the controller parameters, which is why :mod:`feedtune.tuner.search` tunes it by a
derivative-free search on this simulation (see docs/tian.md).

Speed. The recursion is sequential (the accumulator and the clip depend on the previous
period), and its float64 roundings decide real ties (the law's ramps are arithmetic
progressions whose sums land on multiples of value), so it is not vectorised over time:
it runs as a scalar loop with three exact short cuts for a constant command (a step after
t = 0): a run of saturated periods (e = value, sum ≥ 0: one pulse per period, sum
unchanged) is jumped over in one step; coasting at e = raw (the law not binding, the
accumulator on value's float grid) jumps to the period of the next pulse, the partial sums
being exact there; and the simulation stops once the axis is at rest (counter on target,
e = 0: nothing changes any more). A step allocates nothing horizon-long that it keeps: the
command is one number, and the response holds copies of the periods to rest. Tian's
10 rad step at 140 kHz (5 206 periods to rest) takes ≈0.5 ms, the search's typical
point ≈0.4 ms (benchmarks/tian_speed.py). The result is bit for bit the validator's plain
recursion (tests/unit/test_validator_pulse.py).

References
----------
J. Tian, Y. Kamiya, H. Seki, M. Hikizu, "A New Method of Generating Pulse Series for
Numerical Controller" (Kanazawa University): §2 (V-F algorithm, error limit, Figs 1–2),
§3 eqs 1–2 (acceleration), §4 (simulation: 10 rad step, f = 140 kHz, 430 rad/s,
140 krad/s², value = 1; Figs 4–5).
Y. Koren, "Design of Computer Control for Manufacturing Systems", ASME J. Eng. Ind.
101(3), 1979, Reference-Pulse technique, eqs 1–2 (f_m = V_m/BLU; one pulse per
iteration at most).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import Sequence

from feedtune.lazy import np
from feedtune.loops.loop import Drive
from feedtune.loops.protocols import Capability, DeclaredCapabilities

#: automatic horizon: this many times the time a step needs by the plain estimate
HORIZON_SAFETY = 3.0
#: never simulate more periods than this (a 0.5 s horizon at 2 MHz)
MAX_PERIODS = 1_000_000


def _number(x, name: str) -> float:
    """A real number, or TypeError: the pulse simulation cannot take CasADi symbols."""
    if isinstance(x, (int, float, np.integer, np.floating)):
        return float(x)
    try:
        import casadi as ca

        if isinstance(x, (ca.DM,)) and x.numel() == 1:
            return float(x)
    except ImportError:  # pragma: no cover
        pass
    raise TypeError(f"{name}: the pulse simulation is exact and discrete; it needs a number, "
                    f"not {type(x).__name__} (tune it with feedtune.tuner.search)")


@dataclass(frozen=True)
class PulseInput:
    """The position command: ``step`` (``amplitude`` [unit] at t = 0), ``ramp``
    (``velocity`` [unit/s] from t = 0) or ``sine`` (``amplitude`` [unit], ``angular_frequency``
    [rad/s], r = A sin ωt)."""

    kind: str
    amplitude: float = 1.0
    velocity: float = 0.0
    angular_frequency: float = 0.0

    def position(self, t: np.ndarray) -> np.ndarray:
        """r(t) [unit]."""
        if self.kind == "step":
            return np.full_like(t, self.amplitude, dtype=float)
        if self.kind == "ramp":
            return self.velocity * t
        if self.kind == "sine":
            return self.amplitude * np.sin(self.angular_frequency * t)
        raise ValueError(f"unknown input kind {self.kind!r}")


@dataclass(frozen=True)
class PulseResponse:
    """Everything one simulation produced; period i runs over [i T, (i+1) T).

    Attributes
    ----------
    frequency : float
        Sampling frequency f [Hz] = maximum pulse rate [pulses/s].
    pulse_equivalent : float
        δ [unit/pulse].
    error_limit : float
        ``value`` [unit].
    reference : (N,) int array
        Command in whole pulses, sampled at the start of each period.
    pulses : (N,) int8 array
        +1, −1 or 0: the pulse sent in each period (the pulse train).
    error : (N,) float array
        e_i [pulses] after the error limit and the acceleration law (what the V-F
        transformer accumulates).
    at_rest : bool
        The simulation stopped because nothing could change any more (step input, counter
        on target, e = 0): the tail to the horizon is the final state.
    horizon : float
        Simulated (or implied, when at rest) time [s].
    """

    frequency: float
    pulse_equivalent: float
    error_limit: float
    reference: np.ndarray
    pulses: np.ndarray
    error: np.ndarray
    at_rest: bool
    horizon: float

    @cached_property
    def counter(self) -> np.ndarray:
        """n_i [pulses]: the pulse counter after period i."""
        return np.cumsum(self.pulses, dtype=np.int64)

    @property
    def time(self) -> np.ndarray:
        """End of each period [s] (when the counter reads ``counter[i]``)."""
        return (np.arange(len(self.pulses)) + 1.0) / self.frequency

    def end_of(self, period: int) -> float:
        """End of period ``period`` [s]: ``time[period]`` without the whole array."""
        return (period + 1.0) / self.frequency

    @property
    def position(self) -> np.ndarray:
        """Actual position δ·n_i [unit]."""
        return self.counter * self.pulse_equivalent

    @cached_property
    def commanded_velocity(self) -> np.ndarray:
        """v_i = δ f e_i/value [unit/s]: the pulse rate the V-F transformer is asked for."""
        return self.error / self._value_pulses * self.pulse_equivalent * self.frequency

    @property
    def _value_pulses(self) -> float:
        return self.error_limit / self.pulse_equivalent

    @cached_property
    def commanded_acceleration(self) -> np.ndarray:
        """a_i = (v_i − v_{i−1}) f [unit/s²], from rest (v_{−1} = 0)."""
        v = self.commanded_velocity
        a = v.copy()  # v_0 − 0
        np.subtract(v[1:], v[:-1], out=a[1:])
        a *= self.frequency
        return a

    @property
    def commanded_rate(self) -> np.ndarray:
        """|v_i|/δ [pulses/s]: the commanded pulse rate."""
        return np.abs(self.commanded_velocity) / self.pulse_equivalent

    def window(self, seconds: float) -> int:
        """A window of ``seconds`` in whole periods (at least one)."""
        return max(1, int(round(seconds * self.frequency)))

    def measured_velocity(self, periods: int) -> np.ndarray:
        """Pulses counted over the last ``periods`` periods, δ·Δn/(W T) [unit/s] (what a
        frequency counter on the pulse train reads; zero before the start)."""
        n = np.concatenate([np.zeros(periods, dtype=np.int64), self.counter])
        return (n[periods:] - n[:-periods]) * self.pulse_equivalent * self.frequency / periods

    def measured_acceleration(self, periods: int) -> np.ndarray:
        """Change of :meth:`measured_velocity` over one window, per second [unit/s²]."""
        v = np.concatenate([np.zeros(periods), self.measured_velocity(periods)])
        return (v[periods:] - v[:-periods]) * self.frequency / periods


def _track(reference: np.ndarray, value: float, step_limit: float | None) -> tuple[np.ndarray, np.ndarray]:
    """The V-F transformation period by period for a moving command (all in pulses)."""
    count = len(reference)
    pulses = np.zeros(count, dtype=np.int8)
    errors = np.empty(count)
    limit = math.inf if step_limit is None else step_limit
    n = 0
    acc = 0.0
    previous = 0.0
    for i, r in enumerate(reference.tolist()):
        raw = r - n
        e = value if raw > value else (-value if raw < -value else float(raw))
        delta = e - previous
        if delta > limit:
            e = previous + limit
        elif delta < -limit:
            e = previous - limit
        acc += e
        if acc >= value:
            acc -= value
            n += 1
            pulses[i] = 1
        elif acc <= -value:
            acc += value
            n -= 1
            pulses[i] = -1
        errors[i] = e
        previous = e
    return pulses, errors


def _step(target: int, count: int, value: float, step_limit: float | None) -> tuple[np.ndarray, np.ndarray, bool]:
    """The V-F transformation after a step to ``target`` pulses at t = 0, over at most
    ``count`` periods (all in pulses), with the exact short cuts of the module docstring.

    Returns the pulse train and the errors up to the period where the axis came to rest
    (or to ``count``; copies, so no horizon-long buffer stays referenced) and whether it did.
    """
    pulses = np.zeros(count, dtype=np.int8)
    errors = np.empty(count)
    limit = math.inf if step_limit is None else step_limit
    # multiples of ulp(value) below 2·value in magnitude are floats: sums of an integer
    # error and such an accumulator are exact there (the coast short cut needs it)
    grid = math.ulp(value)
    coast = grid <= 1.0
    ramp: list[float] = []
    n = 0
    acc = 0.0
    previous = 0.0
    i = 0
    at_rest = False
    while i < count:
        raw = target - n
        c = value if raw > value else (-value if raw < -value else float(raw))
        delta = c - previous
        if delta > limit or delta < -limit:
            # the acceleration law binds: e moves by ±limit a period (never to 0, so the
            # axis is not at rest) until the clipped error is within reach again
            up = delta > limit
            start = i
            while True:
                e = previous + limit if up else previous - limit
                acc += e
                if acc >= value:
                    acc -= value
                    n += 1
                    pulses[i] = 1
                    raw = target - n
                    c = value if raw > value else (-value if raw < -value else float(raw))
                elif acc <= -value:
                    acc += value
                    n -= 1
                    pulses[i] = -1
                    raw = target - n
                    c = value if raw > value else (-value if raw < -value else float(raw))
                ramp.append(e)
                previous = e
                i += 1
                if i >= count:
                    break
                delta = c - previous
                if not (delta > limit if up else delta < -limit):
                    break
            errors[start:i] = ramp
            ramp.clear()
            continue
        e = c
        if raw == 0 and e == 0.0:
            at_rest = True
            break
        if e == previous:
            # a saturated run: e stays ±value and every period sends a pulse; the sum is
            # unchanged, exactly: the period before (e = ±value too) already rounded
            # acc ± value onto value's grid, so acc ± value ∓ value is acc again
            if e == value and acc >= 0.0 and raw > value + 1:
                run = min(int(math.floor(raw - value)), count - i)
                pulses[i:i + run] = 1
                errors[i:i + run] = value
                n += run
                i += run
                continue
            if e == -value and acc <= 0.0 and raw < -value - 1:
                run = min(int(math.floor(-raw - value)), count - i)
                pulses[i:i + run] = -1
                errors[i:i + run] = -value
                n -= run
                i += run
                continue
            # coasting: e = raw stays until the next pulse, m periods from now; every
            # partial sum acc + j·e (j < m) lies strictly inside ±value on the grid, so
            # it is exact, as the period-by-period sums would be
            if coast and e == raw and (acc / grid).is_integer():
                sign = 1 if e > 0 else -1
                gap = value - acc if sign > 0 else -value - acc
                m = max(1, math.ceil(gap / e))
                while m > 1 and ((acc + (m - 1) * e >= value) if sign > 0 else (acc + (m - 1) * e <= -value)):
                    m -= 1
                while (acc + m * e < value) if sign > 0 else (acc + m * e > -value):
                    m += 1
                if i + m > count:
                    errors[i:count] = e
                    i = count
                    break
                errors[i:i + m] = e
                acc = (acc + (m - 1) * e) + e
                acc = acc - value if sign > 0 else acc + value
                n += sign
                pulses[i + m - 1] = sign
                i += m
                continue
        acc += e
        if acc >= value:
            acc -= value
            n += 1
            pulses[i] = 1
        elif acc <= -value:
            acc += value
            n -= 1
            pulses[i] = -1
        errors[i] = e
        previous = e
        i += 1
    return pulses[:i].copy(), errors[:i].copy(), at_rest


def simulate(pulse_equivalent: float, frequency: float, error_limit: float,
             acceleration_ratio: float | None, command: PulseInput, horizon: float) -> PulseResponse:
    """Simulate the controller over ``horizon`` seconds.

    Parameters
    ----------
    pulse_equivalent : float
        δ [unit/pulse].
    frequency : float
        Sampling frequency f [Hz].
    error_limit : float
        ``value`` [unit] (error limit and V-F threshold, Tian §2).
    acceleration_ratio : float or None
        k [1] of the acceleration law |e_i − e_{i−1}| ≤ value/k (Tian eq 2); None: no law.
    command : PulseInput
    horizon : float
        [s]; a step stops earlier once at rest.
    """
    count = int(math.ceil(horizon * frequency - 1e-9))
    if count > MAX_PERIODS:
        raise ValueError(f"{count} periods to simulate (horizon {horizon:g} s at {frequency:g} Hz); "
                         f"at most {MAX_PERIODS}")
    count = max(count, 1)
    value = error_limit / pulse_equivalent
    step_limit = None if acceleration_ratio is None else value / acceleration_ratio
    if command.kind == "step":
        target = int(np.rint(command.amplitude / pulse_equivalent))
        pulses, errors, at_rest = _step(target, count, value, step_limit)
        reference = np.full(len(pulses), target, dtype=np.int64)
    else:
        t = np.arange(count) / frequency
        reference = np.rint(command.position(t) / pulse_equivalent).astype(np.int64)
        pulses, errors = _track(reference, value, step_limit)
        at_rest = False
    return PulseResponse(frequency=frequency, pulse_equivalent=pulse_equivalent,
                         error_limit=error_limit, reference=reference,
                         pulses=pulses, error=errors, at_rest=at_rest, horizon=horizon)


def automatic_horizon(pulse_equivalent: float, frequency: float, error_limit: float,
                      acceleration_ratio: float | None, command: PulseInput,
                      cycles: float = 2.0) -> float:
    """A horizon [s] long enough for a step to come to rest: HORIZON_SAFETY × (travel at
    v_max + ramp up and down at δf²/k + 20 time constants value/v_max of the linear zone);
    a ramp: the same for its first ``amplitude``-free transient, 20 time constants plus
    the time to reach v_max; a sine: ``cycles`` periods of the sine."""
    v_max = pulse_equivalent * frequency
    ramp = 0.0 if acceleration_ratio is None else 2.0 * acceleration_ratio / frequency
    linear = 20.0 * error_limit / v_max
    if command.kind == "sine":
        return cycles * 2.0 * math.pi / command.angular_frequency
    travel = abs(command.amplitude) / v_max if command.kind == "step" else 0.0
    return HORIZON_SAFETY * (travel + ramp + linear) + 10.0 / frequency


@dataclass(frozen=True)
class MotorCharacteristic:
    """A motor's torque–frequency characteristic as (pulse rate [pulses/s], maximum
    acceleration [unit/s²]) rows, linear in between; above the last rate the motor cannot
    follow (Tian §3: "each motor has a specific torque-frequency characteristic")."""

    rates: tuple[float, ...]
    accelerations: tuple[float, ...]

    @classmethod
    def from_table(cls, table: Sequence[Sequence[float]]) -> "MotorCharacteristic":
        rows = sorted((float(r), float(a)) for r, a in table)
        return cls(tuple(r for r, _ in rows), tuple(a for _, a in rows))

    @property
    def max_rate(self) -> float:
        return self.rates[-1]

    def acceleration(self, rate: np.ndarray) -> np.ndarray:
        """Maximum acceleration [unit/s²] at pulse rate ``rate`` [pulses/s]."""
        return np.interp(rate, self.rates, self.accelerations)

    def margin(self, response: PulseResponse) -> float:
        """min over periods of 1 − |a_i|/a_motor(rate_i), and 1 − (max rate)/(motor's max rate)
        [1]: ≥ 0 iff the commanded acceleration stays within the characteristic at the
        pulse rate of each period (the higher of the rates before and after it) and the
        pulse rate within the table.

        Only the periods with a ≠ 0 can bind, so the ratio is formed there alone (most
        periods of a step run saturated or coast at constant e); the highest rate is the
        rate of the highest |v| (rate is |v|/δ, monotone): the same numbers as over every
        period."""
        velocity = response.commanded_velocity
        acceleration = response.commanded_acceleration
        delta = response.pulse_equivalent
        moving = np.flatnonzero(acceleration)
        worst = 0.0
        if moving.size:
            rate = np.abs(velocity[moving]) / delta
            before = np.abs(velocity[moving - 1]) / delta
            if moving[0] == 0:
                before[0] = 0.0  # from rest
            capacity = self.acceleration(np.maximum(rate, before))
            with np.errstate(divide="ignore", invalid="ignore"):
                worst = float((np.abs(acceleration[moving]) / capacity).max())
        top = float(np.abs(velocity).max(initial=0.0)) / delta
        return float(min(1.0 - worst, 1.0 - top / self.max_rate))


@dataclass(frozen=True, eq=False)
class PulseLoop(DeclaredCapabilities):
    """A reference-pulse controller (Tian's V-F transformation) as a loop feedtune tunes.

    Not a linear loop: metrics read :attr:`response`, the exact simulation, computed once
    on first use. Built from CasADi symbols it can still be inspected, but its response
    raises TypeError: ``exact_only`` tells the tuner to search on the simulation instead
    of building an NLP (:func:`feedtune.tuner.search.problem_class`).

    It has the members every loop has (:class:`feedtune.loops.protocols.Loop`: ``interpolator``,
    ``order``, ``drive`` empty) and offers only
    :attr:`~feedtune.loops.protocols.Capability.PULSE_SIMULATION`, so every linear-loop metric
    declines it.
    """

    pulse_equivalent: object
    frequency: object
    error_limit: object
    acceleration_ratio: object | None
    command: PulseInput
    duration: float | None = None
    motor: MotorCharacteristic | None = None
    position_unit: str = "rad"
    cycles: float = 2.0
    horizon_scale: float = 1.0

    exact_only = True  # the tuner must search on the simulation, not build an NLP
    capabilities = frozenset({Capability.PULSE_SIMULATION})
    interpolator = None
    order = 0
    discrete = True
    drive: Drive = field(default_factory=Drive)

    @property
    def input_kind(self) -> str:
        return self.command.kind

    @cached_property
    def numbers(self) -> dict[str, float | None]:
        """δ, f, value, k as floats (TypeError for symbols)."""
        k = self.acceleration_ratio
        return {"pulse_equivalent": _number(self.pulse_equivalent, "pulse_equivalent"),
                "frequency": _number(self.frequency, "sampling_frequency"),
                "error_limit": _number(self.error_limit, "error_limit"),
                "acceleration_ratio": None if k is None else _number(k, "acceleration_ratio")}

    @cached_property
    def horizon(self) -> float:
        """Simulated time [s]: ``duration``, or :func:`automatic_horizon` × ``horizon_scale``."""
        if self.duration is not None:
            return self.duration
        return self.horizon_scale * automatic_horizon(**self.numbers, command=self.command,
                                                      cycles=self.cycles)

    @cached_property
    def response(self) -> PulseResponse:
        """The exact pulse simulation (cached)."""
        return simulate(**self.numbers, command=self.command, horizon=self.horizon)

    @property
    def controller_acceleration(self) -> float:
        """δ f² [unit/s²] (Tian eq 1), over k with the law (eq 2)."""
        x = self.numbers
        a = x["pulse_equivalent"] * x["frequency"] ** 2
        return a if x["acceleration_ratio"] is None else a / x["acceleration_ratio"]

    def settled(self) -> bool:
        """A step came to rest; a ramp or sine still tracks at the end: over the last
        half of the horizon the error never reached the error limit (not saturated)."""
        response = self.response
        if self.command.kind == "step":
            return response.at_rest
        value = response.error_limit / response.pulse_equivalent
        tail = response.reference - response.counter
        half = len(tail) // 2
        return bool(np.all(np.abs(tail[half:]) < value))

    def stability(self) -> dict:
        """The result's stability block for a pulse loop (no poles: a discrete, nonlinear
        controller): ``stable`` is :meth:`settled`."""
        return {"stable": self.settled(), "domain": "pulse",
                "periods_simulated": int(len(self.response.pulses)),
                "horizon": float(self.horizon)}
