"""Tian's V-F pulse generator for the validator: the algorithm of Tian §2–§3 run period by
period in plain Python, with none of the tuner's short cuts (feedtune/loops/pulse_train.py jumps
over saturated runs), over the horizon the result reports.

Every period T = 1/f: the command rounded to whole pulses minus the counter is the error,
clipped to ±value (the error limit), its change clipped to ±value/k (acceleration law,
eq 2), accumulated; the accumulator passing ±value sends one ± pulse and gives value back
(Fig 2). A constant command stops the run once the counter is on target with zero error
(nothing can change any more). All in pulses; positions are δ × pulses.
"""

from __future__ import annotations

import math

import numpy as np

from feedtune.validate.measurements import Measurement, Phase, measure_entries
from feedtune.validate.model import NotCovered, Response
from feedtune.validate.tolerances import Context


class PulseModel:
    """Validator model of ``pulse_generator``."""

    sampled = True

    def __init__(self, plant: dict, tuned: dict, horizon: float | None = None):
        self.plant = plant
        self.frequency = float(tuned["sampling_frequency"])
        self.period = 1.0 / self.frequency
        self.value = float(tuned["error_limit"])
        self.delta = (plant["pulse_equivalent"] if plant.get("pulse_equivalent") is not None
                      else plant["max_velocity"] / self.frequency)
        self.ratio = tuned.get("acceleration_ratio") if plant.get("acceleration_law", True) else None
        self.position_unit = plant.get("position_unit", "rad")
        self.horizon = horizon
        self._run = None

    @classmethod
    def from_result(cls, plant: dict, tuned: dict, stability: dict | None = None) -> "PulseModel":
        """The model over the horizon [s] the tuner simulated (``stability.horizon``)."""
        return cls(plant, tuned, (stability or {}).get("horizon"))

    def _command(self, t: float) -> float:
        p = self.plant
        kind = p.get("input", "step")
        if kind == "step":
            return p.get("amplitude", 1.0)
        if kind == "ramp":
            return p.get("ramp_velocity", 1.0) * t
        return p.get("amplitude", 1.0) * math.sin(p.get("sine_frequency", 10.0) * t)

    def simulate(self) -> dict:
        """{"reference", "pulses", "error" (per period, in pulses), "at_rest"}."""
        if self._run is not None:
            return self._run
        if self.horizon is None:
            raise NotCovered("the horizon comes from the result (stability.horizon)")
        count = max(1, math.ceil(self.horizon * self.frequency - 1e-9))
        value = self.value / self.delta
        limit = None if self.ratio is None else value / self.ratio
        constant = self.plant.get("input", "step") == "step"
        step = round(self._command(0.0) / self.delta) if constant else None
        command, period, delta = self._command, self.period, self.delta
        reference, pulses, errors = [], [], []
        n, total, previous, at_rest = 0, 0.0, 0.0, False
        # the clips as comparisons, each what min(max(x, lo), hi) returns, bit for bit
        for i in range(count):
            r = step if constant else round(command(i * period) / delta)
            e = float(r - n)
            if -value > e:
                e = -value
            if value < e:
                e = value
            if limit is not None:
                if previous - limit > e:
                    e = previous - limit
                if previous + limit < e:
                    e = previous + limit
            if constant and r == n and e == 0.0:
                at_rest = True
                break
            total += e
            pulse = 0
            if total >= value:
                total -= value
                pulse = 1
            elif total <= -value:
                total += value
                pulse = -1
            n += pulse
            reference.append(r)
            pulses.append(pulse)
            errors.append(e)
            previous = e
        self._run = {"reference": np.array(reference), "pulses": np.array(pulses),
                     "error": np.array(errors), "at_rest": at_rest}
        return self._run

    # -- quantities, from Tian §3–§4 ---------------------------------------------------

    def counter(self) -> np.ndarray:
        return np.cumsum(self.simulate()["pulses"])

    def time(self) -> np.ndarray:
        """End of each period [s]."""
        return (np.arange(self.counter().size) + 1.0) * self.period

    def commanded_velocity(self) -> np.ndarray:
        """δ f e_i/value [unit/s]."""
        return self.simulate()["error"] / (self.value / self.delta) * self.delta * self.frequency

    def commanded_acceleration(self) -> np.ndarray:
        """(v_i − v_{i−1}) f from rest [unit/s²]."""
        v = self.commanded_velocity()
        return np.diff(v, prepend=0.0) * self.frequency

    def metric(self, name: str, options: dict) -> float:
        run, counter, t = self.simulate(), self.counter(), self.time()
        target = int(run["reference"][-1]) if run["reference"].size else 0
        if name == "pulse_final_error":
            end = t[-1] if t.size else 0.0
            goal = self._command(0.0) if self.plant.get("input", "step") == "step" else self._command(end)
            return abs(goal - (counter[-1] if counter.size else 0) * self.delta)
        if name == "pulse_max_velocity":
            return float(np.max(np.abs(self.commanded_velocity()), initial=0.0))
        if name == "peak_commanded_acceleration":
            return float(np.max(np.abs(self.commanded_acceleration()), initial=0.0))
        if name == "pulse_overshoot":
            sign = 1 if target >= 0 else -1
            return float(max(0, int(np.max((counter - target) * sign, initial=0))))
        if name == "pulse_rise_time":
            if target == 0:
                return 0.0
            low, high = np.nonzero(counter / target >= 0.1)[0], np.nonzero(counter / target >= 0.9)[0]
            return math.inf if not high.size else float(t[high[0]] - t[low[0]])
        if name == "pulse_settling_time":
            if not run["at_rest"]:
                return math.inf
            outside = np.nonzero(np.abs(counter - target) > options.get("band", 0.0))[0]
            return 0.0 if not outside.size else float(t[outside[-1] + 1])
        if name == "peak_measured_acceleration":
            w = max(1, int(round(options.get("window", 1e-3) * self.frequency)))
            n = np.concatenate([np.zeros(w), counter])
            v = (n[w:] - n[:-w]) * self.delta * self.frequency / w
            v = np.concatenate([np.zeros(w), v])
            return float(np.max(np.abs((v[w:] - v[:-w]) * self.frequency / w), initial=0.0))
        if name == "sine_tracking_error":  # over the last sine period, at each period's end
            cycle = 2 * math.pi / self.plant.get("sine_frequency", 10.0)
            last = t >= (t[-1] if t.size else 0.0) - cycle
            command = np.array([self._command(x) for x in t[last]])
            return float(np.max(np.abs(command - counter[last] * self.delta), initial=0.0))
        if name == "motor_acceleration_margin":
            table = sorted(self.plant["motor_characteristic"])
            rate = np.abs(self.commanded_velocity()) / self.delta
            rate = np.maximum(rate, np.concatenate([[0.0], rate[:-1]]))
            capacity = np.interp(rate, [r for r, _ in table], [a for _, a in table])
            accel = np.abs(self.commanded_acceleration())
            ratio = np.where(accel > 0, accel / np.where(capacity > 0, capacity, np.inf), 0.0)
            ratio = np.where((accel > 0) & (capacity <= 0), np.inf, ratio)
            return float(min(1 - np.max(ratio, initial=0.0),
                             1 - float(np.max(rate, initial=0.0)) / table[-1][0]))
        raise NotCovered(name)

    # -- the Model protocol ------------------------------------------------------------

    def measurement_tables(self) -> tuple[Phase, ...]:
        """:data:`PULSE_MEASUREMENTS`."""
        return (Phase(PULSE_MEASUREMENTS),)

    def measure(self, result: dict) -> list[dict]:
        """Every pulse metric the result reports, judged against one pulse δ, one period
        1/f and their quotients (feedtune.validate.tolerances): the same integer arithmetic
        runs on both sides, so any gap beyond rounding is a real disagreement."""
        context = Context(period=self.period, pulse=self.delta, position_unit=self.position_unit)
        return measure_entries(self, self.measurement_tables(), result, context)

    def stable(self) -> bool:
        """A step came to rest; a ramp or sine never saturated over the last half."""
        run = self.simulate()
        if self.plant.get("input", "step") == "step":
            return bool(run["at_rest"])
        tail = run["reference"] - self.counter()
        return bool(np.all(np.abs(tail[len(tail) // 2:]) < self.value / self.delta))

    def poles(self):
        raise NotCovered("a nonlinear pulse generator has no poles")

    def frequency_response(self, omega):
        raise NotCovered("a nonlinear pulse generator has no frequency response")

    def circle_test(self, radius, feed):
        raise NotCovered("one axis: no two-axis circle test")

    def responses(self) -> dict[str, Response]:
        run = self.simulate()
        t = self.time()
        reference = run["reference"] * self.delta
        position = self.counter() * self.delta
        if run["at_rest"]:  # the axis stays on target: show a last point at rest
            t = np.append(t, t[-1] + self.period if t.size else self.period)
            reference = np.append(reference, reference[-1] if reference.size else 0.0)
            position = np.append(position, position[-1] if position.size else 0.0)
        kind = self.plant.get("input", "step")
        return {kind: Response(kind, t, reference, position, self.position_unit)}


def _sine_input(model: PulseModel, options: dict) -> bool:
    return model.plant.get("input", "step") == "sine"


#: the metrics :meth:`PulseModel.metric` re-measures: metric → measurement
PULSE_MEASUREMENTS: dict[str, Measurement] = {
    **{name: Measurement(lambda m, o, r, c, name=name: m.metric(name, o))
       for name in ("pulse_final_error", "pulse_max_velocity", "peak_commanded_acceleration",
                    "pulse_overshoot", "pulse_rise_time", "pulse_settling_time",
                    "peak_measured_acceleration", "motor_acceleration_margin")},
    "sine_tracking_error": Measurement(lambda m, o, r, c: m.metric("sine_tracking_error", o),
                                       _sine_input),
}
