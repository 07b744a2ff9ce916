"""A user-defined linear drive: a transfer function, zeros/poles/gain or a state-space model
(continuous, or discrete at its own period), with an input dead time, closed by standard
controllers.

The drive maps its input u (a voltage, a current, a torque: ``input_unit``) to its output
y, after a dead time θ [s]:

    y(s) = P(s) e^{−sθ} u(s),

P given as ``numerator``/``denominator`` in s (highest power first), as zeros, poles and
gain, or as (A, B, C, D) (single input, single output). The output is a **position** when
``output_unit`` is ``m`` or ``rad`` and a **velocity** when it is ``m/s`` or ``rad/s``; the
unit alone decides, and the loop's position is y or y/s accordingly (every position-loop
metric reads that position, in ``m`` or ``rad``).

The loop (Bhatia Fig 18 generalised): the position error r − x, through the position
controller C_p, commands either the drive's input directly (``velocity_controller``
``none``) or a velocity, which a velocity loop C_v closes on the drive's velocity (s·y for
a position output, y for a velocity output); an optional velocity feed-forward k_ff·s·r
(0 ≤ k_ff ≤ 1) adds the reference's velocity to the velocity command. Controllers: P, PI
or PID, a lag or lag-lead compensator and a notch (:mod:`feedtune.plants.controllers`);
the loop is closed from polynomials by :func:`feedtune.plants.cascade.close_loops`, the
skeleton Bhatia's drives share, into a :class:`~feedtune.plants.linear_loop.LinearLoop`
(dead time: exact in frequency responses, Padé in polynomials).

A **discrete model** (the model's ``period`` T [s]) is P(z) at T, as a transfer function
in z, zeros/poles/gain in the z-plane or x(k+1) = A x(k) + B u(k), strictly proper, with a
position output and a dead time of whole samples (``dead_time_samples``, or ``dead_time``
a multiple of T). It is closed by a sampled P, PI or PID position controller at T
(``implementation: sampled``; T is fixed, not a tunable) into a
:class:`~feedtune.loops.sampled_lti.SampledLTILoop` of a
:class:`~feedtune.loops.sampled_plants.DiscretePlant`; no velocity loop and no step-error
integrals (the motion between samples is unknown).

What is refused (exit 2, with the field's pointer): an improper P, empty or non-finite
coefficients, a zero leading denominator coefficient, A/B/C/D of mismatched shapes, a
negative dead time, a compensator, notch or feed-forward in a velocity loop that does not
exist, and a position loop of type 0 (no integrator in the loop: a constant reference
would leave a steady error; give the position controller integral action). The drive may
be unstable: the tuner constrains the closed loop, and the velocity loop when
``stable_velocity_loop``, to be stable.

References
----------
S. Bhatia, "Feed drive design for numerically controlled machine tools", M.S. thesis,
University of Missouri–Rolla, 1971, Ch. IV (Fig 18: the cascade; eq 1: the sensitivity).
K. J. Åström, R. M. Murray, "Feedback Systems", 2nd ed., Princeton, 2021, §9.2 (state
space to transfer function), §11.3 (the cascade with feed-forward).
"""

from __future__ import annotations

import cmath
import itertools
import math
from typing import Annotated, Literal, Mapping, Union

from pydantic import Field, NonNegativeFloat, ValidationInfo, field_validator

from feedtune.lazy import Deferred, np
from feedtune.loops import linalg
from feedtune.loops.frequency import lattice_band
from feedtune.loops.sampled_controllers import cascade_controller, error_controller
from feedtune.loops.sampled_lti import SampledLTILoop
from feedtune.loops.sampled_plants import (WHOLE_SAMPLE_TOL, ContinuousPlant, DiscretePlant,
                                           SampledModelError, split_dead_time)
from feedtune.plants.base import NYQUIST_MARGIN, SETTLING_TIME_CONSTANTS, Plant, Tunable
from feedtune.plants.cascade import close_loops, compensator_corners
from feedtune.plants.compensator import CompensatorKind
from feedtune.plants.controllers import Law, Structure, controller, controller_tunables, corners
from feedtune.plants.linear_loop import Blocks, LinearLoop, pade
from feedtune.schema.model import SpecModel, empty_list
from feedtune.schema.uncertainty import with_numbers

#: default box of the sampling period T [s]: 10 µs (a fast drive's current loop) to 0.5 s
PERIOD_BOUNDS = (1e-5, 0.5)

POSITION_UNITS = ("m", "rad")
VELOCITY_UNITS = ("m/s", "rad/s")
#: a root given as [re, im] stands for the pair re ± j·im
Root = Union[float, Annotated[list[float], Field(min_length=2, max_length=2)]]


def _trim(p: list[float]) -> list[float]:
    """``p`` without leading zeros."""
    i = 0
    while i < len(p) - 1 and p[i] == 0:
        i += 1
    return list(p[i:])


def _nonzero_ends(p: list[float]) -> tuple[int, int]:
    """(first, last) index of ``p``'s nonzero coefficients: the zeros outside them set the
    polynomial's degree and its roots at s = 0."""
    nonzero = [i for i, c in enumerate(p) if c != 0]
    return nonzero[0], nonzero[-1]


def _trailing(p: list[float]) -> tuple[float, int]:
    """(the lowest nonzero coefficient, its power of s) of ``p`` (highest power first)."""
    for power, c in enumerate(reversed(p)):
        if c != 0:
            return c, power
    raise ValueError("the zero polynomial has no lowest coefficient")


def _degree_check(numerator: list[float], denominator: list[float] | None,
                  discrete: bool = False) -> list[float]:
    if not any(numerator):
        raise ValueError("the numerator is zero: the drive does not respond to its input")
    if denominator is None:
        return numerator
    if len(_trim(numerator)) > len(denominator):
        raise ValueError(f"improper transfer function: numerator degree "
                         f"{len(_trim(numerator)) - 1} above the denominator's "
                         f"{len(denominator) - 1} (a drive cannot differentiate its input)")
    if discrete and len(_trim(numerator)) == len(denominator):
        raise ValueError(_NOT_STRICTLY_PROPER)
    return numerator


#: a discrete model whose position answers its input within the same sample
_NOT_STRICTLY_PROPER = (
    "a discrete model must be strictly proper (numerator degree below the denominator's, "
    "no direct feedthrough D): the command of sample k moves the position from sample "
    "k + 1 on, and a position read at the instant its command is computed would close an "
    "algebraic loop")


#: the shortest sampling period a discrete model may have [s]: 1 ns, a thousand times
#: faster than any drive's current loop; a shorter one (2.2e-308 s, found by hypothesis)
#: overflowed only when the loop was formed, refused at /plant instead of at its field
MIN_MODEL_PERIOD = 1e-9


def _period_field():
    """The ``period`` every model form takes: a sampling period makes it a model in z."""
    return Field(
        None, ge=MIN_MODEL_PERIOD,
        description="Sampling period T of a discrete model [s], at least 1e-9 s; omitted: a "
                    "continuous model in s. With it the model is in z (x(k+1) = A x(k) + B u(k)), strictly "
                    "proper, its output a position (m or rad), and it is closed by a sampled "
                    "controller at this same period (implementation 'sampled'; the sampling "
                    "period is then fixed, not tunable)")


class _ModelBase(SpecModel):
    """What the three model forms share: continuous in s, or discrete in z with ``period``."""

    @property
    def discrete(self) -> bool:
        return self.period is not None


class TransferFunction(_ModelBase):
    """P(s) = numerator/denominator, highest power of s first (of z for a discrete model)."""

    type: Literal["transfer_function"]
    period: float | None = _period_field()
    denominator: list[float] = Field(
        min_length=1, max_length=30,
        description="Coefficients of the denominator in s, highest power first [1/s^k "
                    "scaled as the numerator]; in z for a discrete model [1]; its first "
                    "coefficient is not zero")
    numerator: list[float] = Field(
        min_length=1, max_length=30,
        description="Coefficients of the numerator in s (z for a discrete model), highest "
                    "power first [output unit per input unit, times the denominator's scale]")

    @field_validator("denominator")
    @classmethod
    def _leading(cls, denominator):
        if denominator[0] == 0:
            raise ValueError("the leading (highest-power) coefficient is zero; drop it")
        return denominator

    @field_validator("numerator")
    @classmethod
    def _proper(cls, numerator, info: ValidationInfo):
        return _degree_check(numerator, info.data.get("denominator"),
                             info.data.get("period") is not None)

    def polynomials(self) -> tuple[list[float], list[float]]:
        return _trim(self.numerator), list(self.denominator)


def _expand(roots: list) -> list[float]:
    """Π (s − r) over the roots, a [re, im] pair giving (s − re)² + im²."""
    p = [1.0]
    for r in roots:
        if isinstance(r, list):
            re, im = r
            p = linalg.poly_mul(p, [1.0, -2 * re, re * re + im * im])
        else:
            p = linalg.poly_mul(p, [1.0, -r])
    return p


def _count(roots: list) -> int:
    return sum(2 if isinstance(r, list) else 1 for r in roots)


class ZerosPolesGain(_ModelBase):
    """P(s) = gain·Π(s − z)/Π(s − p); a root [re, im] stands for the pair re ± j·im (in z
    for a discrete model)."""

    type: Literal["zpk"]
    period: float | None = _period_field()
    poles: list[Root] = Field(
        max_length=30, description="Poles p [rad/s; z-plane numbers [1] for a discrete "
                                   "model]: a number (a real pole) or [re, im] (the pair "
                                   "re ± j·im, im > 0)")
    zeros: list[Root] = Field(
        default_factory=empty_list, max_length=30,
        description="Zeros [rad/s; z-plane [1] for a discrete model], as the poles; no more "
                    "than there are poles (fewer for a discrete model)")
    gain: float = Field(description="Gain k [output unit per input unit · (rad/s)^(poles − "
                                    "zeros); output per input unit for a discrete model]: "
                                    "the coefficient of the highest powers")

    @field_validator("poles", "zeros")
    @classmethod
    def _pairs(cls, roots):
        for r in roots:
            if isinstance(r, list) and r[1] <= 0:
                raise ValueError(f"a pair [re, im] needs im > 0 (re ± j·im), not {r}")
        return roots

    @field_validator("zeros")
    @classmethod
    def _proper(cls, zeros, info: ValidationInfo):
        poles = info.data.get("poles")
        if poles is not None and _count(zeros) > _count(poles):
            raise ValueError(f"improper: {_count(zeros)} zeros and only {_count(poles)} poles "
                             "(a drive cannot differentiate its input)")
        if (poles is not None and info.data.get("period") is not None
                and _count(zeros) == _count(poles)):
            raise ValueError(_NOT_STRICTLY_PROPER)
        return zeros

    @field_validator("gain")
    @classmethod
    def _nonzero(cls, gain):
        if gain == 0:
            raise ValueError("the gain is zero: the drive does not respond to its input")
        return gain

    def polynomials(self) -> tuple[list[float], list[float]]:
        return linalg.poly_scale(_expand(self.zeros), self.gain), _expand(self.poles)


def _matrix(rows: list[list[float]], shape: tuple[int | None, int | None], what: str):
    n_rows, n_cols = shape
    if n_rows is not None and len(rows) != n_rows:
        raise ValueError(f"{what} needs {n_rows} row{'s' if n_rows != 1 else ''}, not {len(rows)}")
    for i, row in enumerate(rows):
        if n_cols is not None and len(row) != n_cols:
            raise ValueError(f"row {i} of {what} needs {n_cols} entr"
                             f"{'ies' if n_cols != 1 else 'y'}, not {len(row)}")
    return rows


class StateSpace(_ModelBase):
    """ẋ = A x + B u, y = C x + D u (one input, one output); x(k+1) = A x(k) + B u(k) for a
    discrete model."""

    type: Literal["state_space"]
    period: float | None = _period_field()
    a: list[list[float]] = Field(min_length=1, max_length=30,
                                 description="State matrix A, n×n, by rows [1/s; 1 for a "
                                             "discrete model]")
    b: list[list[float]] = Field(min_length=1, max_length=30,
                                 description="Input matrix B, n×1, by rows [state unit per "
                                             "input unit · 1/s; per input unit for a discrete "
                                             "model]")
    c: list[list[float]] = Field(min_length=1, max_length=1,
                                 description="Output matrix C, 1×n [output unit per state unit]")
    d: list[list[float]] = Field([[0.0]], min_length=1, max_length=1,
                                 description="Feedthrough D, 1×1 [output unit per input unit]; "
                                             "must be 0 for a position output")

    @field_validator("a")
    @classmethod
    def _square(cls, a):
        return _matrix(a, (len(a), len(a)), "A (n×n)")

    @field_validator("b")
    @classmethod
    def _column(cls, b, info: ValidationInfo):
        a = info.data.get("a")
        return _matrix(b, (len(a) if a is not None else None, 1), "B (n×1)")

    @field_validator("c")
    @classmethod
    def _row(cls, c, info: ValidationInfo):
        a = info.data.get("a")
        return _matrix(c, (1, len(a) if a is not None else None), "C (1×n)")

    @field_validator("d")
    @classmethod
    def _scalar(cls, d, info: ValidationInfo):
        _matrix(d, (1, 1), "D (1×1)")
        if info.data.get("period") is not None and d[0][0] != 0:
            raise ValueError(_NOT_STRICTLY_PROPER)
        if all(k in info.data for k in ("a", "b", "c")):
            num, _ = StateSpace.model_construct(a=info.data["a"], b=info.data["b"],
                                                c=info.data["c"], d=d).polynomials()
            _degree_check(num, None)
        return d

    def polynomials(self) -> tuple[list[float], list[float]]:
        """C(sI − A)⁻¹B + D as (numerator, denominator) by Faddeev–LeVerrier: adj(sI − A)
        = Σ M_k s^{n−k}, M_1 = I, M_{k+1} = A M_k + c_k I, c_k = −tr(A M_k)/k (Åström &
        Murray §9.2; pure Python: a spec is checked without numerical packages)."""
        a, n = self.a, len(self.a)
        b = [row[0] for row in self.b]
        c, d = self.c[0], self.d[0][0]
        eye = [[float(i == j) for j in range(n)] for i in range(n)]
        m, den, num = eye, [1.0], []
        for k in range(1, n + 1):
            num.append(sum(c[i] * sum(m[i][j] * b[j] for j in range(n)) for i in range(n)))
            am = [[sum(a[i][l] * m[l][j] for l in range(n)) for j in range(n)] for i in range(n)]
            coefficient = -sum(am[i][i] for i in range(n)) / k
            den.append(coefficient)
            m = [[am[i][j] + coefficient * eye[i][j] for j in range(n)] for i in range(n)]
        numerator = linalg.poly_add([0.0] + num, linalg.poly_scale(den, d))
        return _trim(numerator), den


Model = Annotated[Union[TransferFunction, ZerosPolesGain, StateSpace], Field(discriminator="type")]
#: the tags of :data:`Model` (spec error pointers skip them, as the plant's own type)
MODEL_TYPES = ("transfer_function", "zpk", "state_space")


def _discrete_model(info: ValidationInfo):
    """The plant's model, validated so far, when it is discrete (``period``), else None."""
    model = info.data.get("model")
    return model if model is not None and model.discrete else None


class LinearParams(SpecModel):
    """A linear drive of the user's (transfer function, zeros/poles/gain or state space),
    with dead time and standard controllers."""

    type: Literal["linear"]
    model: Model = Field(description="The drive P(s) from input to output, without the dead "
                                     "time: transfer_function, zpk or state_space; with a "
                                     "period [s], a discrete model P(z) at that period")
    output_unit: str = Field(
        pattern=r"^(m|rad|m/s|rad/s)$",
        description="Unit of the drive's output [m, rad, m/s or rad/s]: m or rad make it a "
                    "position, m/s or rad/s a velocity (the position is then its integral)")
    input_unit: str = Field(
        "V", min_length=1, max_length=16, pattern=r"^[^\x00-\x1f\x7f-\x9f]+$",
        description="Unit of the drive's input (V, A, N·m…) [text]: names the gains' units")
    dead_time: NonNegativeFloat = Field(
        0.0, description="Input dead time θ [s] ≥ 0: exact e^{−jωθ} in frequency responses, "
                         "its 4th-order Padé approximant in time responses and stability; "
                         "for a discrete model a whole multiple of its period")
    dead_time_samples: int = Field(
        0, ge=0, le=1000,
        description="Input dead time of a discrete model in whole samples of its period "
                    "[samples] ≥ 0 (instead of dead_time [s]; discrete models only)")
    implementation: Literal["continuous", "sampled"] = Field(
        "continuous", validate_default=True,
        description="continuous: analogue controllers; sampled: a digital controller "
                    "sampling every T (tunable sampling_period [s]), its command held by a "
                    "zero-order hold; a discrete model is closed by a sampled controller only")
    computation_delay: int = Field(
        0, ge=0, le=8, description="Delay between sampling and output, in whole sampling "
                                   "periods [samples] (sampled only)")
    discretisation: Literal["tustin", "backward_euler"] = Field(
        "tustin", description="How the sampled controllers are discretised from their C(s): "
                              "tustin s = (2/T)(z − 1)/(z + 1) or backward_euler "
                              "s = (z − 1)/(T z) (sampled only)")
    velocity_controller: Literal["none", "p", "pi", "pid"] = Field(
        "none", description="Velocity loop inside the position loop: none, p, pi or pid")
    velocity_compensator: CompensatorKind = Field(
        "none", description="Series compensator of the velocity loop: none, lag or lag_lead "
                            "(Bhatia Table 5, App. C)")
    position_controller: Law = Field(
        "p", description="Position controller: p, pi or pid, k_p(1 + 1/(T_i s) + T_d s/(T_d s/N + 1))")
    position_compensator: CompensatorKind = Field(
        "none", description="Series compensator of the position loop: none, lag or lag_lead")
    notch: Literal["none", "position_loop", "velocity_loop"] = Field(
        "none", description="Notch filter (s² + 2δζω s + ω²)/(s² + 2ζω s + ω²) in the "
                            "position or velocity loop's controller, or none")
    velocity_feedforward: float = Field(
        0.0, ge=0.0, le=1.0, description="Velocity feed-forward gain k_ff [1], 0 to 1: adds "
                                         "k_ff·dr/dt to the velocity command (velocity loop only)")
    stable_velocity_loop: bool = Field(
        True, description="Require the velocity loop to be stable on its own (Bhatia Ch. IV; "
                          "continuous implementation only: a sampled loop's velocity loop is "
                          "not constrained on its own)")

    @field_validator("output_unit")
    @classmethod
    def _discrete_position(cls, unit, info: ValidationInfo):
        if _discrete_model(info) is not None and unit not in POSITION_UNITS:
            raise ValueError(f"a discrete model's output is a position (m or rad), not {unit}: "
                             "between its samples the velocity is unknown, so its integral is "
                             "too; give the position model")
        return unit

    @field_validator("dead_time")
    @classmethod
    def _whole_samples(cls, dead_time, info: ValidationInfo):
        model = _discrete_model(info)
        if model is not None and dead_time > 0:
            samples = dead_time / model.period
            if abs(samples - round(samples)) > WHOLE_SAMPLE_TOL * max(samples, 1.0):
                raise ValueError(f"{dead_time:g} s is {samples:g} samples of the discrete "
                                 f"model's period {model.period:g} s: a discrete model's "
                                 "dead time is a whole number of samples (or give "
                                 "dead_time_samples)")
        return dead_time

    @field_validator("dead_time_samples")
    @classmethod
    def _samples_of_discrete(cls, samples, info: ValidationInfo):
        model = info.data.get("model")
        if samples and model is not None and not model.discrete:
            raise ValueError("dead_time_samples applies to a discrete model (model.period) "
                             "only; give a continuous model's dead time in dead_time [s]")
        if samples and info.data.get("dead_time", 0.0) > 0:
            raise ValueError("give the dead time once: dead_time [s] or dead_time_samples")
        return samples

    @field_validator("implementation")
    @classmethod
    def _discrete_is_sampled(cls, implementation, info: ValidationInfo):
        model = _discrete_model(info)
        if model is not None and implementation != "sampled":
            raise ValueError(f"a discrete model (period {model.period:g} s) is closed by a "
                             "sampled controller at its own period: set implementation "
                             "'sampled'")
        return implementation

    @field_validator("velocity_controller")
    @classmethod
    def _discrete_has_no_velocity(cls, law, info: ValidationInfo):
        if law != "none" and _discrete_model(info) is not None:
            raise ValueError("a discrete model gives the position at the samples only, no "
                             "velocity for a velocity loop to read: use velocity_controller "
                             "'none' (a P, PI or PID position loop), or a continuous model")
        return law

    @field_validator("velocity_controller")
    @classmethod
    def _velocity_proper(cls, law, info: ValidationInfo):
        model, unit = info.data.get("model"), info.data.get("output_unit")
        if law != "none" and model is not None and unit in POSITION_UNITS:
            num, den = model.polynomials()
            if den[-1] != 0 and len(num) >= len(den):
                raise ValueError("the drive's velocity s·P(s) is improper (its position "
                                 "responds without lag): no velocity loop can read it")
        return law

    @field_validator("velocity_compensator", "velocity_feedforward")
    @classmethod
    def _needs_velocity_loop(cls, value, info: ValidationInfo):
        if value not in ("none", 0.0) and info.data.get("velocity_controller") == "none":
            raise ValueError(f"{info.field_name} needs a velocity loop: set velocity_controller")
        return value

    @field_validator("notch")
    @classmethod
    def _notch_loop(cls, notch, info: ValidationInfo):
        if notch == "velocity_loop" and info.data.get("velocity_controller") == "none":
            raise ValueError("a notch in the velocity loop needs a velocity loop: set "
                             "velocity_controller, or put the notch in the position_loop")
        return notch

    @field_validator("computation_delay", "discretisation")
    @classmethod
    def _sampled_only(cls, value, info: ValidationInfo):
        default = cls.model_fields[info.field_name].default  # a result's spec holds defaults
        if info.data.get("implementation") == "continuous" and value != default:
            raise ValueError(f"{info.field_name} applies to implementation 'sampled' only")
        return value

    @field_validator("position_controller", "position_compensator", "notch")
    @classmethod
    def _sampled_cascade(cls, value, info: ValidationInfo):
        """The sampled cascade's position loop is a gain (:func:`feedtune.loops.sampled_controllers
        .cascade_controller`): its dynamics go in the velocity loop."""
        if (info.data.get("implementation") == "sampled"
                and info.data.get("velocity_controller", "none") != "none"
                and value not in ("p", "none", "velocity_loop")):
            raise ValueError(f"{info.field_name} {value!r}: a sampled cascade's position "
                             "controller is a plain p gain (put compensators and the notch in "
                             "the velocity loop), or use implementation 'continuous'")
        return value

    @field_validator("position_controller")
    @classmethod
    def _type_one(cls, law, info: ValidationInfo):
        data = info.data
        if any(k not in data for k in ("model", "output_unit", "velocity_controller")):
            return law  # their own errors say what is wrong
        params = cls.model_construct(**{**data, "position_controller": law})
        if Linear(params).loop_type() < 1:
            raise ValueError(f"the position loop has no integrator (type 0): a constant "
                             f"reference would leave a steady error; the drive's position has "
                             f"no pole at s = 0, so use position_controller pi or pid, not {law}")
        return law

    @property
    def position_output(self) -> bool:
        return self.output_unit in POSITION_UNITS


class Linear(Plant):
    """Plant ``linear``: a user's drive in a P/PI/PID position loop, optionally around a
    velocity loop (module docstring)."""

    Params = LinearParams

    def __init__(self, params: LinearParams):
        self.params = params
        self._bands: dict[tuple, tuple[float, float]] = {}  # frequency_band per box
        self._settle_times: dict[float, float] = {}  # _settle_time per T_min
        self._sampled_drive = None  # the sampled loops' plant, built at the first loop's read

    @property
    def position_unit(self) -> str:
        """m or rad: the output's unit, or its integral's for a velocity output."""
        return self.params.output_unit.removesuffix("/s")

    def _structures(self) -> tuple[Structure, Structure | None]:
        p = self.params
        position = Structure(p.position_controller, p.position_compensator,
                             p.notch == "position_loop")
        if p.velocity_controller == "none":
            return position, None
        return position, Structure(p.velocity_controller, p.velocity_compensator,
                                   p.notch == "velocity_loop")

    def tunables(self) -> dict[str, Tunable]:
        p = self.params
        position, velocity = self._structures()
        if getattr(p, "output_unit", None) is None:
            # ``feedtune plants`` lists tunables from a Params holding the structure only:
            # no units are declared, and one name lists one unit for every structure
            position_unit, velocity_unit = "1/s (cascade) or input/output unit", "input·s/output unit"
        else:
            x = p.output_unit.removesuffix("/s")
            position_unit = "1/s" if velocity is not None else f"{p.input_unit}/{x}"
            velocity_unit = f"{p.input_unit}·s/{x}"
        tunables = controller_tunables("position", position, position_unit)
        if velocity is not None:
            tunables.update(controller_tunables("velocity", velocity, velocity_unit))
        model = getattr(p, "model", None)
        discrete = model is not None and model.discrete  # its period is its own (not_tunable)
        if getattr(p, "implementation", "continuous") == "sampled" and not discrete:
            # T_min ≥ θ: the dead time stays within one sample over the default box (a
            # whole number of samples that varies over the box is refused)
            low = max(PERIOD_BOUNDS[0], getattr(p, "dead_time", 0.0))
            tunables["sampling_period"] = Tunable(
                "s", "Sampling period T of the digital controller [s] (required: the "
                     "dead time's whole samples and the step horizon depend on its box)",
                low, PERIOD_BOUNDS[1], required=True)
        return tunables

    def not_tunable(self) -> dict[str, str]:
        """Names a spec might expect among the tunables that this configuration fixes, with
        why (the spec error of a spec that gives one): a discrete model's sampling period."""
        model = getattr(self.params, "model", None)
        if model is None or not model.discrete:
            return {}
        return {"sampling_period": f"a discrete model runs at its own period (model.period "
                                   f"= {model.period!r} s): the sampling period is fixed to "
                                   "it, not tunable; leave sampling_period out"}

    def numbers(self) -> dict[str, float]:
        """The numbers of a continuous loop (each in its unit), by name or dotted path:
        :meth:`loop` also takes them in ``values`` (as NLP parameters, or a robust
        scenario's values). A transfer function's coefficients from its first to its last
        nonzero one (``model.numerator.<i>``, ``model.denominator.<i>``; the zeros outside
        them set its degree and its roots at s = 0, which shape the loop); a zpk model's
        gain, real roots but those at s = 0 (``model.poles.<i>``) and pairs' parts
        (``model.poles.<i>.0`` re, ``.1`` im); the dead time when it is not 0 [s]. None of a state-space model
        (which products of A, B, C vanish sets its transfer function's degree) or of a
        sampled loop (its drive is discretised once, of numbers): :meth:`not_uncertain`."""
        p = self.params
        if p.implementation == "sampled" or isinstance(p.model, StateSpace):
            return {}
        found: dict[str, float] = {}
        model = p.model
        if isinstance(model, TransferFunction):
            for field in ("numerator", "denominator"):
                coefficients = getattr(model, field)
                first, last = _nonzero_ends(coefficients)
                found.update({f"model.{field}.{i}": c for i, c in enumerate(coefficients)
                              if first <= i <= last})
        else:
            found["model.gain"] = model.gain
            for field in ("poles", "zeros"):
                for i, root in enumerate(getattr(model, field)):
                    if isinstance(root, list):
                        found[f"model.{field}.{i}.0"], found[f"model.{field}.{i}.1"] = root
                    elif root != 0:
                        found[f"model.{field}.{i}"] = root
        if p.dead_time > 0:
            found["dead_time"] = p.dead_time
        return found

    def not_uncertain(self) -> dict[str, str]:
        """Why a sampled loop's or a state-space model's numbers, and a zero dead time,
        cannot be uncertain."""
        p = self.params
        if p.implementation == "sampled":
            reason = ("a sampled loop discretises the drive once, of numbers (its ZOH "
                      "transition matrices e^{AT}), so its numbers cannot vary inside one "
                      "NLP; use implementation 'continuous' for a robust design")
            return {"model": reason, "dead_time": reason}
        reasons = {"dead_time": "it is 0: a dead time changes the order of the loop's Padé "
                                "approximant; give a nonzero nominal dead time [s]"}
        if isinstance(p.model, StateSpace):
            reasons["model"] = ("the transfer function of a state-space model has a degree "
                                "set by which products of A, B and C vanish, so its entries "
                                "cannot vary in one loop; give the model as a "
                                "transfer_function or zpk to make its numbers uncertain")
        else:
            reasons["model"] = ("a zero at either end of a coefficient list, or a root at "
                                "s = 0, sets the model's degree or type and is not a number "
                                "of the loop")
        return reasons

    def uncertainty_problem(self, name: str, low: float, high: float) -> str | None:
        """Why values in [low, high] [the number's unit] would change the model's structure:
        a dead time, a pair's imaginary part reaching 0; a gain, a real root, or a transfer
        function's first or last coefficient whose values include 0 (its degree, a root at
        s = 0)."""
        if name == "dead_time":
            return None if low > 0 else (
                f"the dead time reaches {low:g} s, where the loop's Padé approximant changes "
                "order; give a smallest value above 0")
        reaches_zero = low <= 0 <= high
        parts = name.split(".")
        if name == "model.gain":
            return "the gain's values include 0, where the drive stops responding" \
                if reaches_zero else None
        if parts[1] in ("poles", "zeros"):
            if len(parts) == 4:  # a pair's re (.0) or im (.1)
                return ("a pair's imaginary part must stay above 0 (at 0 the pair is a double "
                        "real root)") if parts[3] == "1" and low <= 0 else None
            return ("the root's values include 0, where it becomes an integrator or a "
                    "differentiator") if reaches_zero else None
        if reaches_zero and int(parts[2]) in _nonzero_ends(getattr(self.params.model, parts[1])):
            return ("the coefficient's values include 0, where the model's degree or its "
                    "roots at s = 0 change (the first and last nonzero coefficients)")
        return None

    def model_polynomials(self, numbers: Mapping[str, object] | None = None
                          ) -> tuple[list, list]:
        """P's (numerator, denominator), highest power first, of the spec's model with each
        of ``numbers`` (:meth:`numbers`' names → number or expression) in its place; a
        transfer function's numerator trimmed of its leading zeros, which are not numbers."""
        model = self.params.model
        given = {name.removeprefix("model."): v for name, v in (numbers or {}).items()
                 if name.startswith("model.")}
        if not given:
            return model.polynomials()
        data = with_numbers(model.model_dump(), given)
        if isinstance(model, TransferFunction):
            lead = len(model.numerator) - len(_trim(model.numerator))
            return data["numerator"][lead:], data["denominator"]
        return ZerosPolesGain.model_construct(**data).polynomials()

    def drive_polynomials(self, numbers: Mapping[str, object] | None = None
                          ) -> tuple[list, list, list | None, list]:
        """(n_g, d_g, n_x, q): velocity per input n_g/d_g, position per input n_x/(q·d_g)
        (n_x None: the same as n_g), without the dead time, with ``numbers`` in place
        (:meth:`model_polynomials`); a pole or zero at s = 0 that the differentiation or
        integration meets is cancelled exactly (at s = 0 in the spec's own model: such a
        root is never a number)."""
        nominal_num, nominal_den = self.params.model.polynomials()
        num, den = self.model_polynomials(numbers)
        if self.params.position_output:
            if nominal_den[-1] == 0:  # an integrating drive: velocity n/(d/s), position n/(s·d/s)
                return num, den[:-1], None, [1, 0]
            return num + [0.0], den, num, [1]  # velocity s·n/d
        if nominal_num[-1] == 0:  # a velocity output with a zero at s = 0: position (n/s)/d
            return num, den, num[:-1], [1]
        return num, den, None, [1, 0]

    def state_space(self):
        """(A, B, C, D) as float arrays of the drive from input to output (its declared
        unit), without the dead time: the spec's own matrices, or the controllable canonical
        form of its transfer function; and the dead time θ [s]. For engines that build their
        own loop (a sampled-data controller). A discrete model's matrices are those of
        x(k+1) = A x(k) + B u(k) and its dead time is its whole samples times its period."""
        model = self.params.model
        if isinstance(model, StateSpace):
            a, b, c, d = (np.array(m, dtype=float) for m in (model.a, model.b, model.c, model.d))
            return a, b, c, d, self.dead_time
        num, den = model.polynomials()
        num, den = np.array(num) / den[0], np.array(den) / den[0]
        n = len(den) - 1
        num = np.concatenate([np.zeros(n + 1 - len(num)), num])
        a = np.zeros((n, n))
        a[0, :], a[1:, :-1] = -den[1:], np.eye(n - 1)
        b = np.zeros((n, 1))
        b[0, 0] = 1.0
        c = (num[1:] - num[0] * den[1:]).reshape(1, n)
        return a, b, c, np.array([[num[0]]]), self.dead_time

    @property
    def dead_time(self) -> float:
        """θ [s]: ``dead_time``, or a discrete model's ``dead_time_samples`` times its period."""
        p = self.params
        if p.model.discrete and p.dead_time_samples:
            return p.dead_time_samples * p.model.period
        return p.dead_time

    @property
    def dead_time_samples(self) -> int:
        """A discrete model's dead time in whole samples of its period."""
        p = self.params
        return p.dead_time_samples or round(p.dead_time / p.model.period)

    def loop_type(self) -> int:
        """Integrators in the open position loop: its poles at s = 0 net of zeros there,
        counted on the drive's polynomials with a controller of each law's shape (k_p = 1,
        T_i = 1 s: an integrator for PI and PID). A discrete model's integrators are its
        poles at z = 1 (:func:`_roots_at_one`) net of zeros there."""
        position, velocity = self._structures()
        model = self.params.model
        if model.discrete:  # no velocity loop (LinearParams): the position controller's own
            num, den = model.polynomials()
            return (_roots_at_one(den) - _roots_at_one(num)
                    + (0 if position.law == "p" else 1))
        n_g, d_g, n_x, q = self.drive_polynomials()

        def shape(structure):
            return (1.0, [1.0], [1.0]) if structure.law == "p" else (1.0, [1.0, 1.0], [1.0, 0.0])

        closed = close_loops(n_g, d_g, shape(position),
                             None if velocity is None else shape(velocity), n_x, q)

        def trailing_zeros(p):
            return len(p) - len(_trim(list(reversed(p))))

        return trailing_zeros(closed.open_denominator) - trailing_zeros(closed.open_numerator)

    def loop(self, values: Mapping[str, object], box: Mapping[str, tuple[float, float]],
             horizon_scale: float = 1.0) -> LinearLoop | SampledLTILoop:
        """The closed loop at ``values`` (expressions or numbers per tunable name): a
        :class:`LinearLoop`, or for ``implementation: sampled`` a
        :class:`~feedtune.loops.sampled_lti.SampledLTILoop` (:meth:`sampled_loop`)."""
        p = self.params
        if p.implementation == "sampled":
            return self.sampled_loop(values, box, horizon_scale)
        numbers = {name: values[name] for name in self.numbers() if name in values}
        n_g, d_g, n_x, q = self.drive_polynomials(numbers)
        dead_time = numbers.get("dead_time", p.dead_time)
        position_structure, velocity_structure = self._structures()
        position = controller("position", position_structure, values)
        velocity = (None if velocity_structure is None
                    else controller("velocity", velocity_structure, values))
        gains = [c for c in (position, velocity) if c is not None]
        parts = [(c.gain, c.numerator, c.denominator) for c in gains]
        pn, pd = pade(dead_time) if p.dead_time > 0 else ([1.0], [1.0])
        delayed_x = None if n_x is None else linalg.poly_mul(n_x, pn)
        closed = close_loops(linalg.poly_mul(n_g, pn), linalg.poly_mul(d_g, pd), parts[0],
                             parts[1] if len(parts) > 1 else None, delayed_x, q,
                             p.velocity_feedforward)
        blocks = None
        if p.dead_time > 0:
            blocks = Blocks(n_g, d_g, n_g if n_x is None else n_x, q, dead_time, parts[0],
                            parts[1] if len(parts) > 1 else None, p.velocity_feedforward)
        product = None
        nominal_n, nominal_d, _, _ = self.drive_polynomials()
        if nominal_d[-1] != 0 and nominal_n[-1] != 0:  # Bhatia's |G(0) K'_v K'_p| with the k_p's
            product = position.gain
            if velocity is not None:
                product = product * velocity.gain
            product = product * n_g[-1] / d_g[-1]
        return LinearLoop(
            open_numerator=closed.open_numerator,
            open_denominator=closed.open_denominator,
            inner_characteristic=closed.inner if p.stable_velocity_loop else None,
            loop_gain_product=product,
            frequency_band=self.frequency_band(box),
            error_numerator=closed.error_numerator,
            blocks=blocks,
            loop_type=self.loop_type())

    def sampled_state_space(self) -> tuple:
        """(A, B, C) [numbers] with C reading the position, balanced: the drive's own for a
        position output, for a velocity output with one more state, the position ∫y dt
        (ẋ_p = C x + D u, C = [0 … 0 1]).

        The states are rescaled, x = S x̃ (S diagonal, powers of two: exact), so that
        [[A, B], [C, 0]] has balanced rows and columns (scipy ``matrix_balance``): the
        companion form of the README's two-mass drive has A up to 3e6 and C up to 1e9, and
        its closed loop's zI − Φ a condition number of 7e21, which left its frequency
        response without a correct digit; balanced, every response is python-control's to
        1e-8 (tests/unit/test_sampled_linear.py). C and C A, all the loop reads, are
        unchanged by the rescaling."""
        from scipy.linalg import matrix_balance

        a, b, c, d, _ = self.state_space()
        if not self.params.position_output:
            n = a.shape[0]
            a_x = np.zeros((n + 1, n + 1))
            a_x[:n, :n], a_x[n, :n] = a, c[0]
            a, b, c = a_x, np.vstack([b, d]), np.eye(1, n + 1, n)
        n = a.shape[0]
        system = np.block([[a, b], [c, np.zeros((1, 1))]])
        _, (scaling, _) = matrix_balance(system, permute=False, separate=True)
        states = scaling[:n] / scaling[n]  # S: the input/output keep their scale
        return a * states[None, :] / states[:, None], b / states[:, None], c * states[None, :]

    def _sampled_plant(self) -> ContinuousPlant | DiscretePlant:
        """The drive as the sampled loops' plant: a :class:`ContinuousPlant` behind the
        hold, or a :class:`DiscretePlant` at its own period, of :meth:`sampled_state_space`.
        It holds the spec's numbers only, so it is built once per plant, when the first
        loop reads it, and shared by every loop of the plant (one is built at every point
        of a robust search, a batch's reports and the contract tests' grids: the balancing
        and the checks were repeated per loop). Its arrays are read-only."""
        if self._sampled_drive is None:
            p = self.params
            if p.model.discrete:
                drive = DiscretePlant(*self.sampled_state_space(), period=p.model.period,
                                      dead_time_samples=self.dead_time_samples)
            else:
                drive = ContinuousPlant(*self.sampled_state_space(), dead_time=p.dead_time)
            for matrix in (drive.a, drive.b, drive.c, drive.d):
                matrix.flags.writeable = False
            self._sampled_drive = drive
        return self._sampled_drive

    def sampled_loop(self, values: Mapping[str, object],
                     box: Mapping[str, tuple[float, float]],
                     horizon_scale: float = 1.0) -> SampledLTILoop:
        """The digital loop: the drive behind a ZOH, sampled every T = ``sampling_period``,
        controllers discretised (``discretisation``), commands held ``computation_delay``
        samples late. Without a velocity loop u = C_p(z)(r − y)
        (:func:`~feedtune.loops.sampled_controllers.error_controller`); with one, the P position
        gain around C_v(z) reading the sampled velocity C A x, k_ff feed-forward
        (:func:`~feedtune.loops.sampled_controllers.cascade_controller`).

        Raises
        ------
        SampledModelError
            Its message starts with the spec's pointer (``/plant/...`` or
            ``/tunables/sampling_period``).
        """
        p = self.params
        self.check_sampled(box)
        if p.model.discrete:  # its own period, fixed (not a tunable)
            period = t_min = t_max = p.model.period
        else:
            period = values["sampling_period"]
            t_min, t_max = box["sampling_period"]
        position_structure, velocity_structure = self._structures()
        position = controller("position", position_structure, values)
        if p.model.discrete:
            samples = self.dead_time_samples
            plant = Deferred(_engine(self._sampled_plant), discrete=True,
                             period=p.model.period, dead_time_samples=samples)
        else:
            plant = Deferred(_engine(self._sampled_plant), discrete=False)
        if velocity_structure is None:
            law = Deferred(_engine(lambda: error_controller(
                linalg.poly_scale(position.numerator, position.gain), position.denominator,
                period, p.discretisation)))
        else:
            velocity = controller("velocity", velocity_structure, values)
            law = Deferred(_engine(lambda: cascade_controller(
                position.gain, linalg.poly_scale(velocity.numerator, velocity.gain),
                velocity.denominator, period, p.discretisation, p.velocity_feedforward)))
        try:
            return SampledLTILoop(
                plant, law, period, (t_min, t_max), delay=p.computation_delay,
                horizon=SETTLING_TIME_CONSTANTS * self._settle_time(t_min) * horizon_scale,
                frequency_band=(self.frequency_band(box)[0],
                                math.pi / t_min * NYQUIST_MARGIN))
        except SampledModelError as exc:
            raise SampledModelError(_spec_pointer(str(exc))) from None

    def check_sampled(self, box: Mapping[str, tuple[float, float]]) -> None:
        """What the sampled loop's engine refuses, checked in pure Python before any matrix
        is built (``feedtune validate`` builds none, issue 15): a continuous model's
        dead-time split over the sampling period's box
        (:func:`~feedtune.loops.sampled_plants.split_dead_time`), its position without direct
        feedthrough, and C B = 0 where a velocity loop reads v = C A x.

        Raises
        ------
        SampledModelError
            Its message starts with the spec's pointer.
        """
        p = self.params
        model = p.model
        if model.discrete:
            return  # its period is its own; what it may be is checked by LinearParams
        t_min, t_max = box["sampling_period"]
        split_dead_time(p.dead_time, None, t_max, (t_min, t_max))  # refuses varying samples
        if isinstance(model, StateSpace):
            b, c, d = [row[0] for row in model.b], model.c[0], model.d[0][0]
        else:  # C B and D of the canonical form: the numerator's first coefficients
            num, den = model.polynomials()
            num = [0.0] * (len(den) - len(num)) + num
            b, c, d = [1.0], [num[1] / den[0] if len(num) > 1 else 0.0], num[0] / den[0]
        if p.position_output and d != 0:
            raise SampledModelError("/plant/model: the position responds to the input "
                                    "without lag (D ≠ 0): a sampled loop reads the position "
                                    "at the instant it computes the command; give a strictly "
                                    "proper model")
        if p.velocity_controller != "none":
            # the velocity is read as C A x of the position's states (ContinuousPlant
            # .velocity_row: |C B| within 1e-12 of Σ|c_i b_i|, products the balancing keeps);
            # of a velocity output's states (its integral added) C B is the drive's D
            c_b, scale = d, 0.0
            if p.position_output:
                c_b = sum(ci * bi for ci, bi in zip(c, b))
                scale = sum(abs(ci * bi) for ci, bi in zip(c, b))
            if abs(c_b) > 1e-12 * scale:
                raise SampledModelError("/plant/model: the velocity ẏ is measured as C A x, "
                                        "which needs C B = 0 (relative degree ≥ 2)")

    def _settle_time(self, period_min: float) -> float:
        """2·(the drive's slowest time constant 1/|Re p| over its stable nonzero poles) + θ +
        (computation delay + 1)·T_min [s]: the time scale of a step's transient, as
        :meth:`feedtune.plants.software_servo.SoftwareServo.loop`'s 2τ + dead time. A
        discrete model's poles z map to p = ln(z)/T, |Re p| = −ln|z|/T. Roots in pure Python
        (:func:`feedtune.loops.linalg.roots`): a scale, computed without numpy, once per
        T_min (a sampled loop is built at every point of a robust search, a batch's reports
        and the contract tests' grids)."""
        if period_min not in self._settle_times:
            self._settle_times[period_min] = self._slowest_transient(period_min)
        return self._settle_times[period_min]

    def _slowest_transient(self, period_min: float) -> float:
        """:meth:`_settle_time` [s], computed."""
        model = self.params.model
        _, den = model.polynomials()
        if model.discrete:
            decays = [-math.log(abs(z)) / model.period for z in linalg.roots(den)
                      if 0 < abs(z) < 1]
        else:
            decays = [-r.real for r in linalg.roots(den) if r.real < 0]
        slowest = 1 / min(decays) if decays else 0.0
        return (2 * slowest + self.dead_time
                + (self.params.computation_delay + 1) * period_min)

    def frequency_band(self, box: Mapping[str, tuple[float, float]]) -> tuple[float, float]:
        """(low, high) [rad/s]: two decades beyond every frequency where the open loop L can
        turn or cross unity over the tunables' ``box``.

        * the drive's poles and zeros |p| (roots at s = 0 left out; a discrete model's roots
          z as |ln z|/T, its Nyquist frequency π/T);
        * the controllers' and compensators' corners at the ends of their boxes (1/T_i,
          1/T_d, N/T_d, 1/τ, the notch frequency) and 1/θ;
        * a cascade's position gain k_p [1/s]: the outer loop's crossover, a frequency;
        * a direct position loop's k_p [input/output unit] is a gain, not a frequency: the
          crossovers it can cause beyond every corner are those of L's asymptotes,
          |L| ≈ k_p|b/a|/ω^m = 1 (:func:`_asymptote_crossovers`), at the box's vertices.

        A discrete model keeps its k_p box as a low-end bound (its low-frequency asymptote
        is not computed; only the low end of a sampled band is read, the high end is the
        Nyquist frequency). Computed once per box (the loop is built at every start and
        for every report; a PID + notch box has 2^7 vertices).

        The ends are widened onto the frequency grid's lattice
        (:func:`~feedtune.loops.frequency.lattice_band`), so the grid's points do not move
        with them."""
        key = tuple(sorted(box.items()))
        if key not in self._bands:
            self._bands[key] = self._frequency_band(box)
        return self._bands[key]

    def _frequency_band(self, box: Mapping[str, tuple[float, float]]) -> tuple[float, float]:
        model = self.params.model
        num, den = model.polynomials()
        if model.discrete:
            # a root within 1e-9 of z = 1 is an integrator (_roots_at_one), not a corner at
            # |ln z|/T ≈ 1e-16/T: c2d leaves a few ulps there
            found = [abs(cmath.log(z)) / model.period for p in (num, den)
                     for z in linalg.roots(p) if z != 0 and abs(z - 1) > 1e-9]
            found.append(math.pi / model.period)
            found += list(box.get("position_controller.kp", ()))
        else:
            found = [abs(z) for p in (num, den) for z in linalg.roots(p) if z != 0]
            if self.params.velocity_controller == "none":
                found += self._asymptote_crossovers(box)
            else:
                found += list(box.get("position_controller.kp", ()))
        found += corners(box) + compensator_corners(box)
        if self.dead_time > 0:
            found.append(1 / self.dead_time)
        found = [f for f in found if f > 0 and math.isfinite(f)] or [1.0]
        return lattice_band((min(found) / 100, max(found) * 100))

    def _asymptote_crossovers(self, box: Mapping[str, tuple[float, float]]) -> list[float]:
        """Where the asymptotes of a direct position loop's L = k_p·C·P cross |L| = 1
        [rad/s], at every vertex of the position controller's box (its k_p, law, compensator
        and notch): below the lowest corner L ≈ k_p(b_l/a_l)/s^m (m the loop type), above
        the highest L ≈ k_p(b_h/a_h)/s^r (r the relative degree), so ω = |k_p b/a|^(1/m)
        and ^(1/r). A crossover between the corners lies within the corners' span."""
        n_g, d_g, n_x, q = self.drive_polynomials()
        n_p = _trim(list(n_g if n_x is None else n_x))
        d_p = _trim(linalg.poly_mul(q, d_g))
        structure, _ = self._structures()
        names = sorted(name for name in box if name.split(".")[0] in
                       ("position_controller", "position_compensator", "notch"))
        out = []
        for ends in itertools.product(*(sorted(set(box[name])) for name in names)):
            c = controller("position", structure, dict(zip(names, ends)))
            num = _trim(linalg.poly_mul(c.numerator, n_p))
            den = _trim(linalg.poly_mul(c.denominator, d_p))
            low_n, low_d = _trailing(num), _trailing(den)
            m = low_d[1] - low_n[1]  # integrators net of zeros at s = 0
            if m > 0:
                out.append(abs(c.gain * low_n[0] / low_d[0]) ** (1 / m))
            r = len(den) - len(num)  # relative degree
            if r > 0:
                out.append(abs(c.gain * num[0] / den[0]) ** (1 / r))
        return out


def _engine(build):
    """``build`` with the engine's :class:`SampledModelError` given the spec's pointer."""
    def built():
        try:
            return build()
        except SampledModelError as exc:
            raise SampledModelError(_spec_pointer(str(exc))) from None
    return built


def _roots_at_one(p: list[float]) -> int:
    """How often z = 1 is a root of ``p`` (highest power first): divisions by (z − 1) whose
    remainder p(1) is within 1e-9 of Σ|p_k| (c2d's (z − 1)(z − e^{−T/τ}) leaves a
    remainder of a few ulps; a pole further from 1 than 1e-9 is a lag, not an integrator)."""
    count = 0
    while len(p) > 1:
        quotient, remainder = [], 0.0
        for c in p:  # synthetic division by (z − 1)
            remainder = remainder + c
            quotient.append(remainder)
        if abs(quotient.pop()) > 1e-9 * sum(abs(c) for c in p):
            break
        p, count = quotient, count + 1
    return count


#: the engine's field paths (:mod:`feedtune.loops.sampled_plants`) as the spec's pointers
_POINTERS = {"/plant/dead_time": "/plant/dead_time", "/tunables/sampling_period":
             "/tunables/sampling_period", "/controller": "/plant/discretisation",
             "/plant": "/plant/model"}


def _spec_pointer(message: str) -> str:
    """``message`` with the engine's leading field path replaced by the spec's pointer."""
    path, _, text = message.partition(": ")
    for engine, spec in _POINTERS.items():
        if path == engine or path.startswith(engine + "/"):
            return f"{spec}: {text}"
    return message
