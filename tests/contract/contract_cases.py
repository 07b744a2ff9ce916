"""Cases shared by the contract tests, generated from the registries.

A new plant enrols by adding its module and registry line, plus one entry in
PLANT_EXAMPLES (physical parameters the tests can build it with; a test fails with a
clear message until that entry exists). Every value of every ``Literal`` field of its
Params (e.g. ``technique``, a compensator kind) becomes one configuration automatically;
tunables named ``<part>.<constant>`` (compensator time constants) are thinned on the grids
(see GRID_BUDGET) so that plants with many tunables stay fast. A new metric enrols
with no change here unless its Options need a value without a default that is not in
OPTION_SAMPLES (again a test says so).
"""

from __future__ import annotations

import ast
import itertools
import json
import math
import typing
from dataclasses import dataclass
from functools import cached_property, lru_cache
from pathlib import Path

import casadi as ca
import numpy as np

import feedtune
from feedtune.expr import Magnitude
from feedtune.objectives import METRICS
from feedtune.plants import PLANTS

#: the package's source directory (the modules the AST contracts read)
PACKAGE_ROOT = Path(feedtune.__file__).resolve().parent


@lru_cache(maxsize=None)
def _package_sources() -> tuple:
    """(path, source text) of every module of ``feedtune/``, sorted by path, read once per
    test process."""
    return tuple((path, path.read_text(encoding="utf-8"))
                 for path in sorted(PACKAGE_ROOT.rglob("*.py")))


@lru_cache(maxsize=None)
def _package_tree(path: Path, source: str) -> ast.Module:
    return ast.parse(source, filename=str(path))


@lru_cache(maxsize=None)
def package_trees(*names: str) -> tuple:
    """(path, syntax tree) of the modules of ``feedtune/``, sorted by path, each parsed at
    most once per test process for the contracts that walk them (test_loop_protocol.py's
    two, test_status_vocabulary.py's): ≈ 1 s of CPU a parse of the whole package. Read
    them only.

    With ``names``: only the modules whose source contains one of them, for a contract
    that looks for an identifier (an ``ast.Name`` or attribute named so can only be in a
    module whose text holds that name, non-ASCII look-alikes that Python's NFKC folding
    turns into it aside: ``Capability`` is in 17 of the 192 modules, so the others need no
    parse); without: every module."""
    return tuple((path, _package_tree(path, source)) for path, source in _package_sources()
                 if not names or any(name in source for name in names))


#: physical parameters per plant; software_servo: Koren 1979 design example (τ = 20 ms,
#: BLU = 5 µm, V_m = 40 mm/s); hydraulic_rotary: Bhatia 1971 Ch. IV in SI units, as in
#: examples/bhatia-1971-hydraulic.json (K_s = 10 in/V, K_q/D_m = 1 rad/(s·in), ω_n = 75
#: rad/s and ξ = 0.5 as he takes them for design, β_e, V_t, J_t, K_ce for the load path)
PLANT_EXAMPLES: dict[str, dict] = {
    "software_servo": {"time_constant": 0.02, "blu": 5e-6, "max_velocity": 0.04},
    # ward_leonard: Palm, System Dynamics 3rd ed., Problem 11.35 (generator-fed DC motor)
    "ward_leonard": {"generator_gain": 50.0, "generator_field_resistance": 2.0,
                     "generator_field_inductance": 0.2, "armature_resistance": 1.0,
                     "armature_inductance": 0.2, "torque_constant": 0.5,
                     "back_emf_constant": 0.5, "inertia": 10.0, "viscous_damping": 20.0},
    "hydraulic_rotary": {
        "torque_motor_gain": 0.254, "torque_motor_time_constant": 0.01,
        "flow_gain": 5.44225e-6, "displacement": 1.38233e-7,
        "hydraulic_natural_frequency": 75.0, "hydraulic_damping": 0.5,
        "bulk_modulus": 689475729.0, "total_volume": 4.91612e-6, "inertia": 0.0135582,
        "leakage_coefficient": 5.0123e-14,
    },
    # pulse_generator: Tian et al.'s controller scaled down (δ = 1 mrad per pulse, a 0.5 rad
    # step) so that a simulation at the default box's middle (f = 31.6 kHz) takes a few ms
    "pulse_generator": {"pulse_equivalent": 1e-3, "amplitude": 0.5,
                        "motor_characteristic": [[0.0, 2e5], [1e6, 2e5]]},
    # linear: a servo motor as a user writes it, 1 rad/s per volt with a 10 ms mechanical
    # time constant, integrated to the shaft angle: θ/u = 1/(s(0.01 s + 1)) [rad/V]
    "linear": {"model": {"type": "transfer_function", "numerator": [1.0],
                         "denominator": [0.01, 1.0, 0.0]}, "output_unit": "rad"},
}

#: the drive of PLANT_EXAMPLES["linear"] with a 300 Hz resonance (ζ = 0.05), as zeros,
#: poles and gain; and its velocity per volt as state space (output rad/s)
_RESONANT_ZPK = {"type": "zpk", "zeros": [], "gain": 1885.0**2 / 0.01,
                 "poles": [0.0, -100.0, [-94.25, 1882.6]]}
_VELOCITY_SS = {"type": "state_space", "a": [[-100.0]], "b": [[1.0]], "c": [[100.0]]}

#: the drive of PLANT_EXAMPLES["linear"] as a discrete model: its zero-order-hold equivalent
#: at T = 2 ms (Franklin, Powell & Workman ch. 4), ((T − τ + τa) z + τ − τa − aT) /
#: ((z − 1)(z − a)), a = e^{−T/τ}, as a transfer function in z and as the state space of
#: [position, velocity]
_T, _TAU = 0.002, 0.01
_A = math.exp(-_T / _TAU)
_B1, _B0 = _T - _TAU * (1 - _A), _TAU * (1 - _A) - _A * _T
_DISCRETE_TF = {"type": "transfer_function", "period": _T, "numerator": [_B1, _B0],
                "denominator": [1.0, -(1 + _A), _A]}
#: and a drive without an integrator for a PI position loop (type 1; with Koren's drive a
#: PI makes the loop type 2, C_v infinite): a lag and a resonant pair, DC gain 1
_DISCRETE_ZPK = {"type": "zpk", "period": _T, "zeros": [], "poles": [0.9, [0.5, 0.3]],
                 "gain": 0.034}
_DISCRETE_SS = {"type": "state_space", "period": _T,
                "a": [[1.0, _TAU * (1 - _A)], [0.0, _A]], "b": [[_B1], [1 - _A]],
                "c": [[1.0, 0.0]]}

#: configurations beyond one per Literal value (options that change the loop's shape)
EXTRA_VARIANTS: dict[str, list[dict]] = {
    "software_servo": [{"technique": "sampled_data", "computation_delay": 1},
                       {"technique": "sampled_data", "computation_delay": 2},
                       # Koren's drive with the dead time L = T/2 as its Padé approximant
                       {"technique": "sampled_data", "model": "pade"},
                       # Sato's software servo (ideal drive, L = 1.5 Δt_p), exact and Padé,
                       # behind a linear interpolator (the tunable reference_interval)
                       {"technique": "sampled_data", "time_constant": None,
                        "computation_delay": 1, "interpolation": "linear"},
                       {"technique": "sampled_data", "time_constant": None,
                        "computation_delay": 1, "interpolation": "linear", "model": "pade"}],
    "hydraulic_rotary": [
        # Bhatia's design: a lag-lead in both loops (8 tunables, order 8)
        {"velocity_compensator": "lag_lead", "position_compensator": "lag_lead"},
        # the velocity loop need not be stable on its own: no inner-loop conditions
        {"velocity_compensator": "lag_lead", "stable_velocity_loop": False},
        # the torque motor's armature mode (App. A3: ω_o = 775 rad/s): two more poles
        {"torque_motor_natural_frequency": 775.0},
        # ω_n and ξ computed from β_e, V_t, J_t, K_ce (App. A2) instead of given
        {"hydraulic_natural_frequency": None, "hydraulic_damping": None},
    ],
    # Tian's eq 1 controller: no acceleration law (and so no acceleration_ratio tunable)
    "pulse_generator": [{"acceleration_law": False}],
    "linear": [
        # the velocity loop's compensators and notch, which need a velocity loop
        {"velocity_controller": "pi", "velocity_compensator": "lag"},
        {"velocity_controller": "p", "velocity_compensator": "lag_lead",
         "position_compensator": "lag_lead"},  # Bhatia's structure
        {"velocity_controller": "p", "notch": "velocity_loop", "model": _RESONANT_ZPK},
        {"velocity_controller": "pid", "velocity_feedforward": 0.5},
        {"velocity_controller": "pi", "stable_velocity_loop": False},
        # the dead time (Padé polynomials, exact frequency responses)
        {"dead_time": 0.002},
        {"dead_time": 0.002, "velocity_controller": "pi", "velocity_feedforward": 1.0},
        # a velocity output, integrated to the position; given as state space
        {"output_unit": "rad/s", "model": _VELOCITY_SS},
        {"output_unit": "rad/s", "model": _VELOCITY_SS, "velocity_controller": "pi"},
        # the sampled implementation's other discretisation of the velocity PI
        {"implementation": "sampled", "discretisation": "backward_euler",
         "velocity_controller": "pi"},
        # a discrete model at its own period: P; PI on a drive without integrator, with a
        # dead time of one sample; a computation delay and a dead time in seconds (2 samples)
        {"implementation": "sampled", "model": _DISCRETE_TF},
        {"implementation": "sampled", "model": _DISCRETE_ZPK, "position_controller": "pi",
         "dead_time_samples": 1},
        {"implementation": "sampled", "model": _DISCRETE_SS, "computation_delay": 1,
         "dead_time": 2 * _T},
    ],
}

#: values for metric options that have no default (the circle of the circular metrics)
OPTION_SAMPLES: dict[str, object] = {"radius": 0.01, "feed": 0.02}

GRID_POINTS = 7  # per tunable, geometric, across the default bounds

#: Tunables that shape a loop rather than set its gain: the constants of a part of the
#: plant, named ``<part>.<constant>`` (compensator time constants). A product grid of 7
#: points over Bhatia's 8 tunables (two gains, two lag-leads) would hold 7⁸ ≈ 5.8 million
#: loops, so these get SECONDARY_POINTS points where the whole grid stays within
#: GRID_BUDGET, and otherwise one: the geometric middle of their default box (e.g. τ1 = τ2
#: = 31.6 ms, τ12 = 0.1 s). The gains always get GRID_POINTS. Compensator shapes the
#: grid misses are covered by RANDOM_POINTS seeded log-uniform points over the whole box
#: in the stability contract (:func:`stability_sample`).
def is_secondary(name: str) -> bool:
    return "." in name


SECONDARY_POINTS = 3
GRID_BUDGET = 500
RANDOM_POINTS = 200


def literal_fields(model) -> dict[str, tuple]:
    """Fields of a pydantic model whose annotation is a Literal, with their values."""
    out = {}
    for name, info in model.model_fields.items():
        if typing.get_origin(info.annotation) is typing.Literal:
            out[name] = typing.get_args(info.annotation)
    return out


class _Json(str):
    """An override whose value is a JSON object or array (a plant's model), kept as its
    JSON text so that a configuration stays hashable; :func:`_thawed` reads it back."""


def _frozen(value):
    return _Json(json.dumps(value, sort_keys=True)) if isinstance(value, (dict, list)) else value


def _thawed(overrides) -> dict:
    return {k: json.loads(v) if isinstance(v, _Json) else v for k, v in dict(overrides).items()}


@dataclass(frozen=True)
class PlantConfig:
    id: str
    key: str
    overrides: tuple

    @cached_property
    def plant(self):
        """The configuration's plant, built once (its Params validated by pydantic): the
        contracts read it for every case and every point (``log_point``, ``tunables``),
        and build loops from it, as the tuner builds every loop of a spec from one plant."""
        cls = PLANTS[self.key]
        return cls(cls.Params(type=self.key, **{**PLANT_EXAMPLES[self.key], **_thawed(self.overrides)}))

    @cached_property
    def tunables(self):
        """The plant's tunables (read only)."""
        return self.plant.tunables()

    @property
    def default_box(self) -> dict[str, tuple[float, float]]:
        return {name: (t.min, t.max) for name, t in self.tunables.items()}


def _builds(key: str, overrides: dict) -> bool:
    """Whether the example parameters with ``overrides`` make a valid Params (a Literal
    field without a default, such as ``technique``, must be given)."""
    cls = PLANTS[key]
    try:
        cls.Params(type=key, **{**PLANT_EXAMPLES[key], **overrides})
    except ValueError:
        return False
    return True


def _model_label(model: _Json) -> str:
    """A model's type, ``(z)`` appended for a discrete one (its ``period``)."""
    model = json.loads(model)
    return model["type"] + ("(z)" if "period" in model else "")


def plant_configs() -> list[PlantConfig]:
    """One configuration per Literal value, plus EXTRA_VARIANTS, plus the defaults.

    Overrides that restate a field's default are dropped, so ``velocity_compensator=none``
    and the defaults are one configuration, not two.
    """
    configs = []
    for key, cls in PLANTS.items():
        if key not in PLANT_EXAMPLES:
            continue  # test_every_plant_has_example_parameters reports it
        fields = cls.Params.model_fields
        variants = [{}]
        for field, values in literal_fields(cls.Params).items():
            if field != "type":
                variants += [{field: value} for value in values]
        variants += EXTRA_VARIANTS.get(key, [])
        seen = set()
        for overrides in variants:
            overrides = {k: v for k, v in overrides.items()
                         if fields[k].is_required() or v != fields[k].default
                         or k in PLANT_EXAMPLES[key]}
            frozen = tuple(sorted((k, _frozen(v)) for k, v in overrides.items()))
            if frozen in seen or not _builds(key, overrides):
                continue
            seen.add(frozen)
            label = ",".join(f"{k}={v}" if not isinstance(v, _Json) else f"{k}={_model_label(v)}"
                             for k, v in frozen) or "defaults"
            configs.append(PlantConfig(f"{key}[{label}]", key, frozen))
    return configs


ALL_CONFIGS = plant_configs()


def is_exact_only(config: PlantConfig) -> bool:
    """An exact (discrete) simulation, not a linear loop: the pulse generator. Its contract
    is tests/contract/test_exact_loop_contract.py; the linear-loop contracts skip it."""
    tunables = config.tunables
    probe = config.plant.loop({n: t.max for n, t in tunables.items()}, config.default_box)
    return bool(probe.exact_only)


#: linear loops (every contract in test_plant_contract.py / test_metric_contract.py)
CONFIGS = [c for c in ALL_CONFIGS if not is_exact_only(c)]
CONFIG_IDS = [c.id for c in CONFIGS]
#: exact-only loops (test_exact_loop_contract.py)
EXACT_CONFIGS = [c for c in ALL_CONFIGS if is_exact_only(c)]
EXACT_CONFIG_IDS = [c.id for c in EXACT_CONFIGS]


def _axis(t, points: int, secondary: bool = False) -> np.ndarray:
    """``points`` geometric points across a tunable's default bounds; one: the middle. A
    secondary tunable's points stay inside the box (1/6, 1/2 and 5/6 of its log range for
    three): the compensators' boxes reach τ1τ2 = 1e-8 s² with τ12 = 100 s, poles 1e12
    apart, a loop the eigenvalue check calls ambiguous; the random points still reach the
    whole box (:func:`stability_sample`)."""
    if points == 1:
        return np.array([math.sqrt(t.min * t.max)])
    if secondary:
        low, high = math.log(t.min), math.log(t.max)
        return np.exp(low + (high - low) * (2 * np.arange(points) + 1) / (2 * points))
    return np.geomspace(t.min, t.max, points)


@lru_cache(maxsize=None)
def _grid(config: PlantConfig) -> tuple:
    tunables = config.tunables
    n_secondary = sum(1 for name in tunables if is_secondary(name))
    n_primary = len(tunables) - n_secondary
    points = (SECONDARY_POINTS
              if GRID_POINTS**n_primary * SECONDARY_POINTS**n_secondary <= GRID_BUDGET else 1)
    axes = [_axis(t, points, True) if is_secondary(name) else _axis(t, GRID_POINTS)
            for name, t in tunables.items()]
    return tuple(dict(zip(tunables, map(float, point))) for point in itertools.product(*axes))


def grid(config: PlantConfig) -> list[dict[str, float]]:
    """Geometric grid over the default box (secondary tunables thinned, see above)."""
    return [dict(point) for point in _grid(config)]


def stability_sample(config: PlantConfig) -> list[dict[str, float]]:
    """:func:`grid`, plus RANDOM_POINTS seeded log-uniform points over the whole default box
    when the grid thinned some tunables (so compensator shapes off the grid are tested)."""
    points = grid(config)
    tunables = config.tunables
    if any(is_secondary(name) for name in tunables):
        rng = np.random.default_rng(sum(map(ord, config.id)))
        low = np.log([t.min for t in tunables.values()])
        high = np.log([t.max for t in tunables.values()])
        for u in rng.random((RANDOM_POINTS, len(tunables))):
            points.append(dict(zip(tunables, map(float, np.exp(low + u * (high - low))))))
    return points


def as_array(x) -> np.ndarray:
    """A number, DM or expression of numbers as a 2-D float array (an expression evaluated
    by ``ca.evalf``; a DM read as it is, without building a Function to evaluate it: the
    stability contract reads ≈ 20 000 matrices)."""
    if isinstance(x, (int, float)):
        return np.array([[float(x)]])
    if isinstance(x, ca.DM):
        return np.array(x, dtype=float)
    return np.array(ca.evalf(ca.MX(x)), dtype=float)


def assert_allclose_each(pairs, rtol: float, atol: float) -> None:
    """``numpy.testing.assert_allclose(actual, desired, rtol=rtol, atol=atol,
    err_msg=message)`` for each (actual, desired, message) of ``pairs`` (float arrays), in
    order. Where every pair has one shape and finite numbers, all are first compared at
    once by the same inequality (numpy's ``isclose`` on finite numbers, |actual − desired|
    ≤ atol + rtol·|desired|); if that holds for every number, each assert_allclose would
    pass, and none is called. Otherwise each is called in turn, so a failure is the same
    failure with the same message (the plant contract compares ≈ 6 000 arrays, ≈ 35 µs
    each in assert_allclose)."""
    pairs = list(pairs)
    if all(actual.shape == desired.shape for actual, desired, _ in pairs):
        actual = np.concatenate([a.ravel() for a, _, _ in pairs] + [np.zeros(0)])
        desired = np.concatenate([d.ravel() for _, d, _ in pairs] + [np.zeros(0)])
        if (np.all(np.isfinite(actual)) and np.all(np.isfinite(desired))
                and np.all(np.abs(actual - desired) <= atol + rtol * np.abs(desired))):
            return
    for actual, desired, message in pairs:
        np.testing.assert_allclose(actual, desired, rtol=rtol, atol=atol, err_msg=message)


def exact_expr(value):
    """The expression a metric's value reports: a Magnitude's signed expression, the refined
    ``exact`` of a value the tuner reformulates (a supremum or crossing over ω), or the
    value itself."""
    if isinstance(value, Magnitude):
        return value.expr
    return getattr(value, "exact", value)


def as_float(x) -> float:
    return float(as_array(exact_expr(x)).ravel()[0])


def numpy_stable(matrix: np.ndarray, discrete: bool) -> tuple[bool, float]:
    """Stability from numpy eigenvalues, and the distance to the boundary (for ambiguity)."""
    return _pole_verdict(np.linalg.eigvals(matrix), discrete)


def eigenvalues_each(matrices: list[np.ndarray]) -> list[np.ndarray]:
    """``numpy.linalg.eigvals`` of each matrix, those of one shape in one stacked call
    (LAPACK's geev on each in turn: the same eigenvalues as one call a matrix, without
    numpy's Python wrapper for each of the ≈ 18 000 matrices of the stability contract)."""
    out: list = [None] * len(matrices)
    shapes: dict[tuple, list[int]] = {}
    for index, matrix in enumerate(matrices):
        shapes.setdefault(matrix.shape, []).append(index)
    for indices in shapes.values():
        for index, poles in zip(indices, np.linalg.eigvals(np.stack([matrices[i] for i in indices]))):
            out[index] = poles
    return out


def _pole_verdict(poles: np.ndarray, discrete: bool) -> tuple[bool, float]:
    """:func:`numpy_stable` of a matrix with eigenvalues ``poles``."""
    if discrete:
        radius = float(np.max(np.abs(poles)))
        return radius < 1, abs(radius - 1)
    abscissa = float(np.max(poles.real))
    return abscissa < 0, abs(abscissa) / max(1.0, float(np.max(np.abs(poles))))


def numpy_loop_stable(loop) -> tuple[bool, float]:
    """Every matrix of ``loop.stability_matrices()`` (closed loop, and an inner loop that
    must be stable on its own) stable by numpy eigenvalues; the smallest distance to the
    boundary among the matrices that decide the answer."""
    return numpy_matrices_stable(
        [as_array(m) for m in loop.stability_matrices().values()], loop.discrete)


def numpy_matrices_stable(matrices, discrete: bool, poles=None) -> tuple[bool, float]:
    """:func:`numpy_loop_stable` of a loop's stability matrices already read as arrays
    (``poles``: their eigenvalues, when computed already by :func:`eigenvalues_each`)."""
    results = ([numpy_stable(m, discrete) for m in matrices] if poles is None
               else [_pole_verdict(p, discrete) for p in poles])
    stable = all(s for s, _ in results)
    deciding = [d for s, d in results if s == stable]  # unstable: only the unstable ones
    return stable, min(deciding)


def nominal(config: PlantConfig) -> dict[str, float]:
    """The numpy-stable grid point closest (in log space) to the geometric middle of the box.

    The geometric middle itself need not be stable (a sampled loop with a large gain and a
    long period is not), so the contract asks only that a stable point exists in the box.
    The grid is tried nearest first (ties in grid order), so the search usually stops at
    the first point instead of building the loop at every one of up to GRID_BUDGET points
    (this runs at collection, in every test worker).
    """
    return _nominal_search(config)[0]


@lru_cache(maxsize=None)
def _nominal_search(config: PlantConfig) -> tuple:
    """(:func:`nominal`, the loop of numbers there with the default box that the search
    found stable): :func:`nominal_loop` is that loop, not a second one built from the same
    numbers (a sampled loop's matrices are assembled once, not again in the tests)."""
    tunables = config.tunables
    middle = np.array([0.5 * (math.log(t.min) + math.log(t.max)) for t in tunables.values()])
    points = grid(config)
    distances = [float(np.linalg.norm(np.log(list(point.values())) - middle)) for point in points]
    for index in sorted(range(len(points)), key=distances.__getitem__):  # stable: ties in order
        loop = config.plant.loop(points[index], config.default_box)
        stable, _ = numpy_loop_stable(loop)
        if stable:
            return points[index], loop
    raise AssertionError(f"{config.id}: no stable point on the default grid")


def narrow_box(config: PlantConfig, point: dict[str, float]) -> dict[str, tuple[float, float]]:
    """A factor-2 box around ``point`` inside the default bounds (a spec narrowing its search)."""
    return {name: (max(t.min, point[name] / 2), min(t.max, point[name] * 2))
            for name, t in config.tunables.items()}


def symbolic_loop(config: PlantConfig, box):
    """(z, loop): the loop as a function of log-tunables z, as the tuner builds it."""
    names = list(config.tunables)
    z = ca.MX.sym("log_tunables", len(names))
    return z, config.plant.loop({name: ca.exp(z[i]) for i, name in enumerate(names)}, box)


def nominal_loop(config: PlantConfig):
    """The loop of numbers at the nominal point with the plant's default bounds: one per
    configuration and test process (the one :func:`nominal` found stable), read by the
    plant contract's tests at that point and the metric contract's default-box cases (as
    the validator and the reports read every metric of a spec on one loop). Read it only."""
    return _nominal_search(config)[1]


@lru_cache(maxsize=None)
def default_symbolic_loop(config: PlantConfig):
    """(z, loop): :func:`symbolic_loop` over the plant's default bounds, one per
    configuration and test process, read by the plant contract's stability conditions and
    its symbolic-against-numeric numbers (the NLP builds one loop for all its rows). Read
    it only."""
    return symbolic_loop(config, config.default_box)


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
    """(config, metric name, options) for every combination the metric says it supports
    (a new list of the cases found once per test process: the metric and validator
    contracts both enrol them at collection)."""
    return list(_metric_cases())


@lru_cache(maxsize=None)
def _metric_cases() -> tuple:
    cases = []
    for config in CONFIGS:
        try:
            loop = numeric_loop(config)  # the loop its cases are then evaluated on
        except AssertionError:
            continue  # no nominal point: test_loop_is_stable_at_a_nominal_point reports it
        for name, cls in METRICS.items():
            try:
                variants = option_variants(cls)
            except KeyError:
                continue  # test_metric_options_can_be_sampled reports it
            for options in variants:
                if cls().supports(loop, options):
                    cases.append((config, name, options))
    return tuple(cases)


def exact_nominal(config: PlantConfig) -> dict[str, float]:
    """The geometric middle of an exact-only plant's default box."""
    return {name: math.sqrt(t.min * t.max) for name, t in config.tunables.items()}


def exact_metric_cases() -> list[tuple[PlantConfig, str, object]]:
    """(config, metric name, options) for every metric that supports an exact-only loop
    (a new list of the cases found once per test process, as :func:`metric_cases`)."""
    return list(_exact_metric_cases())


@lru_cache(maxsize=None)
def _exact_metric_cases() -> tuple:
    cases = []
    for config in EXACT_CONFIGS:
        loop = config.plant.loop(exact_nominal(config), config.default_box)
        for name, cls in METRICS.items():
            try:
                variants = option_variants(cls)
            except KeyError:
                continue
            for options in variants:
                if cls().supports(loop, options):
                    cases.append((config, name, options))
    return tuple(cases)


@lru_cache(maxsize=None)
def numeric_loop(config: PlantConfig):
    """The loop of numbers at the nominal point, in its factor-2 box: one per configuration,
    shared by its metrics (as the validator evaluates every metric of a spec on one loop;
    what they share, such as the gain crossover, is located once on it). Read it only."""
    point = nominal(config)
    return config.plant.loop(point, narrow_box(config, point))


@lru_cache(maxsize=None)
def numeric_metric(config: PlantConfig, name: str, options):
    """(metric value, loop) on :func:`numeric_loop`: evaluated once for every test that
    needs it."""
    loop = numeric_loop(config)
    return METRICS[name]().evaluate(loop, options), loop
