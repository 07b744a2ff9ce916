"""Cases shared by the contract tests, generated from the registries.

A new plant enrols by adding its module and registry line, plus one entry in
PLANT_EXAMPLES (physical parameters the tests can build it with; a test fails with a
clear message until that entry exists). Every value of every ``Literal`` field of its
Params (e.g. ``technique``) becomes one configuration automatically. A new metric enrols
with no change here unless its Options need a value without a default that is not in
OPTION_SAMPLES (again a test says so).
"""

from __future__ import annotations

import itertools
import math
import typing
from dataclasses import dataclass
from functools import lru_cache

import casadi as ca
import numpy as np

from feedtune.expr import Magnitude
from feedtune.objectives import METRICS
from feedtune.plants import PLANTS

#: physical parameters per plant; software_servo: Koren 1979 design example (τ = 20 ms,
#: BLU = 5 µm, V_m = 40 mm/s)
PLANT_EXAMPLES: dict[str, dict] = {
    "software_servo": {"time_constant": 0.02, "blu": 5e-6, "max_velocity": 0.04},
}

#: configurations beyond one per Literal value (integer options that change the loop's shape)
EXTRA_VARIANTS: dict[str, list[dict]] = {
    "software_servo": [{"technique": "sampled_data", "computation_delay": 1},
                       {"technique": "sampled_data", "computation_delay": 2}],
}

#: values for metric options that have no default (the circle of the circular metrics)
OPTION_SAMPLES: dict[str, object] = {"radius": 0.01, "feed": 0.02}

GRID_POINTS = 7  # per tunable, geometric, across the default bounds


def literal_fields(model) -> dict[str, tuple]:
    """Fields of a pydantic model whose annotation is a Literal, with their values."""
    out = {}
    for name, info in model.model_fields.items():
        if typing.get_origin(info.annotation) is typing.Literal:
            out[name] = typing.get_args(info.annotation)
    return out


@dataclass(frozen=True)
class PlantConfig:
    id: str
    key: str
    overrides: tuple

    @property
    def plant(self):
        cls = PLANTS[self.key]
        return cls(cls.Params(type=self.key, **PLANT_EXAMPLES[self.key], **dict(self.overrides)))

    @property
    def tunables(self):
        return self.plant.tunables()

    @property
    def default_box(self) -> dict[str, tuple[float, float]]:
        return {name: (t.min, t.max) for name, t in self.tunables.items()}


def plant_configs() -> list[PlantConfig]:
    configs = []
    for key, cls in PLANTS.items():
        if key not in PLANT_EXAMPLES:
            continue  # test_every_plant_has_example_parameters reports it
        variants = [{}]
        for field, values in literal_fields(cls.Params).items():
            if field != "type":
                variants += [{field: value} for value in values]
        variants += EXTRA_VARIANTS.get(key, [])
        seen = set()
        for overrides in variants:
            frozen = tuple(sorted(overrides.items()))
            if frozen in seen or not overrides:
                continue
            seen.add(frozen)
            label = ",".join(f"{k}={v}" for k, v in frozen)
            configs.append(PlantConfig(f"{key}[{label}]", key, frozen))
    return configs


CONFIGS = plant_configs()
CONFIG_IDS = [c.id for c in CONFIGS]


def grid(config: PlantConfig) -> list[dict[str, float]]:
    tunables = config.tunables
    axes = [np.geomspace(t.min, t.max, GRID_POINTS) for t in tunables.values()]
    return [dict(zip(tunables, map(float, point))) for point in itertools.product(*axes)]


def as_array(x) -> np.ndarray:
    if isinstance(x, (int, float)):
        return np.array([[float(x)]])
    return np.array(ca.evalf(ca.MX(x)), dtype=float)


def as_float(x) -> float:
    if isinstance(x, Magnitude):
        x = x.expr
    return float(as_array(x).ravel()[0])


def numpy_stable(matrix: np.ndarray, discrete: bool) -> tuple[bool, float]:
    """Stability from numpy eigenvalues, and the distance to the boundary (for ambiguity)."""
    poles = np.linalg.eigvals(matrix)
    if discrete:
        radius = float(np.max(np.abs(poles)))
        return radius < 1, abs(radius - 1)
    abscissa = float(np.max(poles.real))
    return abscissa < 0, abs(abscissa) / max(1.0, float(np.max(np.abs(poles))))


@lru_cache(maxsize=None)
def nominal(config: PlantConfig) -> dict[str, float]:
    """The numpy-stable grid point closest (in log space) to the geometric middle of the box.

    The geometric middle itself need not be stable (a sampled loop with a large gain and a
    long period is not), so the contract asks only that a stable point exists in the box.
    """
    tunables = config.tunables
    middle = np.array([0.5 * (math.log(t.min) + math.log(t.max)) for t in tunables.values()])
    best = None
    for point in grid(config):
        loop = config.plant.loop(point, config.default_box)
        stable, _ = numpy_stable(as_array(loop.state_matrix), loop.discrete)
        if stable:
            distance = float(np.linalg.norm(np.log(list(point.values())) - middle))
            if best is None or distance < best[0]:
                best = (distance, point)
    if best is None:
        raise AssertionError(f"{config.id}: no stable point on the default grid")
    return best[1]


def narrow_box(config: PlantConfig, point: dict[str, float]) -> dict[str, tuple[float, float]]:
    """A factor-2 box around ``point`` inside the default bounds (a spec narrowing its search)."""
    return {name: (max(t.min, point[name] / 2), min(t.max, point[name] * 2))
            for name, t in config.tunables.items()}


def symbolic_loop(config: PlantConfig, box):
    """(z, loop): the loop as a function of log-tunables z, as the tuner builds it."""
    names = list(config.tunables)
    z = ca.MX.sym("log_tunables", len(names))
    return z, config.plant.loop({name: ca.exp(z[i]) for i, name in enumerate(names)}, box)


def log_point(config: PlantConfig, point: dict[str, float]) -> np.ndarray:
    return np.log([point[name] for name in config.tunables])


def option_variants(metric_cls) -> list:
    """Every combination of the Options' Literal values; required fields from OPTION_SAMPLES.

    Raises KeyError naming a required field that has no sample value.
    """
    options = metric_cls.Options
    literals = literal_fields(options)
    fixed = {}
    for name, info in options.model_fields.items():
        if name not in literals and info.is_required():
            fixed[name] = OPTION_SAMPLES[name]
    names = list(literals)
    return [options(**fixed, **dict(zip(names, values)))
            for values in itertools.product(*(literals[n] for n in names))]


def metric_cases() -> list[tuple[PlantConfig, str, object]]:
    """(config, metric name, options) for every combination the metric says it supports."""
    cases = []
    for config in CONFIGS:
        try:
            point = nominal(config)
        except AssertionError:
            continue  # test_loop_is_stable_at_a_nominal_point reports it
        loop = config.plant.loop(point, narrow_box(config, point))
        for name, cls in METRICS.items():
            try:
                variants = option_variants(cls)
            except KeyError:
                continue  # test_metric_options_can_be_sampled reports it
            for options in variants:
                if cls().supports(loop, options):
                    cases.append((config, name, options))
    return cases
