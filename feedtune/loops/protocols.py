"""The contracts of the pipeline plant → Loop → metrics → tuner, written as typed protocols.

A :class:`Plant` turns a spec's parameters and the tunables' values into a :class:`Loop`;
metrics read the Loop, never the plant; the tuner reads the Loop and the metrics. Every
loop has the members of :class:`Loop`. Beyond them a loop offers *capabilities*
(:class:`Capability`), each the members of one protocol below (:data:`PROTOCOLS`), as
python-control's ``LTI`` declares ``isdtime()`` rather than letting callers probe for
attributes:

* a loop class declares what it can offer in its class attribute ``capabilities``;
* ``loop.offers(capability)`` says whether this loop offers it: declared, and not withdrawn
  by the loop's data (a sampled loop without a frequency band has no frequency responses,
  a loop without a load input no load path; :data:`WITHDRAWN`);
* a metric's ``supports`` asks ``loop.offers(Capability.X)``, never ``hasattr``: a
  misspelt capability is an AttributeError at once, and
  ``tests/contract/test_loop_protocol.py`` fails for a class without the members of a
  capability it declares, for one with all of them that does not declare it, and for a
  capability named anywhere in ``feedtune`` that :class:`Capability` does not define.

Expressions (the members typed ``Expr``) are CasADi expressions of the tunables, or
numbers for a loop of numbers (:mod:`feedtune.expr`): the same code serves the NLP and the
evaluation of a tuned design.
"""

from __future__ import annotations

import enum
from typing import TYPE_CHECKING, Any, Callable, ClassVar, Mapping, Protocol

if TYPE_CHECKING:  # annotations only: loop.py imports this module
    from feedtune.loops.loop import Drive, Integrator, IntegratorLag, Interpolator, StepIntegrals
    from feedtune.loops.pulse_train import MotorCharacteristic, PulseInput, PulseResponse

#: a CasADi expression (MX, SX or DM) or a float: a number of a loop of numbers
Expr = Any
#: (Re, Im) of a complex response at ω [rad/s]
Complex = tuple[Any, Any]


class Capability(enum.Enum):
    """What a loop may offer beyond :class:`Loop`; each value's protocol is in :data:`PROTOCOLS`."""

    #: a linear loop the NLP can hold: state matrices, characteristic polynomial,
    #: stability and settling conditions (:class:`LinearDynamics`)
    LINEAR = "linear"
    #: closed-loop responses at s = jω or z = e^{jωT} over a band (:class:`FrequencyLoop`)
    FREQUENCY_RESPONSE = "frequency_response"
    #: the open loop L at s = jω or z = e^{jωT} (:class:`OpenLoop`)
    OPEN_LOOP = "open_loop"
    #: C_v of a type-1 loop (:class:`VelocityConstantLoop`)
    VELOCITY_CONSTANT = "velocity_constant"
    #: exact symbolic IAE/ISE/ITAE of a position step (:class:`StepErrorLoop`)
    EXACT_STEP_ERROR = "exact_step_error"
    #: transfer functions as numbers, for exact time responses (:class:`NumericTransferLoop`)
    NUMERIC_TRANSFER = "numeric_transfer"
    #: position per load torque (:class:`LoadLoop`)
    LOAD_INPUT = "load_input"
    #: Bhatia's loop-gain product |G K'_v K'_p| (:class:`LoopGainLoop`)
    LOOP_GAIN_PRODUCT = "loop_gain_product"
    #: step responses summed sample by sample over a horizon (:class:`SampleHorizonLoop`)
    SAMPLE_HORIZON = "sample_horizon"
    #: Koren's sampled loop: the held command and its numbers (:class:`HeldCommandLoop`)
    HELD_COMMAND = "held_command"
    #: an exact pulse simulation, not a linear loop (:class:`PulseSimulation`)
    PULSE_SIMULATION = "pulse_simulation"


class Loop(Protocol):
    """What every loop has, whatever it offers.

    Attributes
    ----------
    capabilities : frozenset of Capability
        What this class of loop can offer (a class attribute).
    exact_only : bool
        True: not a linear loop; the tuner searches on its exact simulation
        (:mod:`feedtune.tuner.search`) instead of building an NLP.
    discrete : bool
        Sampled (z-domain, period T) rather than continuous.
    order : int
        States of the closed loop [1] (0 for a simulation).
    interpolator : Interpolator or None
        The linear interpolator in front of the loop (Sato et al.), if any.
    drive : Drive
        Physical data of the axis some metrics need (BLU, V_m, τ, counter width).
    """

    capabilities: ClassVar[frozenset[Capability]]
    exact_only: ClassVar[bool]
    discrete: bool
    order: int
    interpolator: Interpolator | None
    drive: Drive

    def offers(self, capability: Capability) -> bool:
        """Whether this loop offers ``capability`` (declared, not withdrawn by its data)."""

    def embedded_reads(self) -> frozenset[str] | None:
        """The numbers that may shape the loop's graph (a horizon, a frequency band) that
        it read so far, by name; None when it does not record them (the tuner's structure
        cache then keys on all of them: feedtune.tuner.cache.StructureKey)."""


class LinearDynamics(Loop, Protocol):
    """:attr:`Capability.LINEAR`: a linear closed loop whose numbers are expressions of the
    tunables, with what the NLP holds (stability and settling conditions) and what the
    pole metrics read.

    Attributes
    ----------
    state_matrix : Expr
        A closed-loop state matrix: its eigenvalues are the closed-loop poles (in z for a
        discrete loop).
    characteristic_polynomial : list of Expr
        Monic closed-loop characteristic polynomial, highest power first.
    period : Expr or None
        Sampling period T [s] of a discrete loop; None for a continuous one.
    unrolled_steps : int
        Loop steps inside the expressions built so far (a cost hint for the tuner).
    """

    state_matrix: Expr
    characteristic_polynomial: list
    period: Expr | None
    unrolled_steps: int

    def natural_frequency(self) -> Expr:
        """ω_n [rad/s] of a second-order loop (Koren eqs 10, 17–19)."""

    def damping_ratio(self) -> Expr:
        """ζ [1] of a second-order loop (Koren eqs 9, 19)."""

    def stability_conditions(self) -> list:
        """Expressions all positive iff the loop (and any inner loop) is stable."""

    def settling_conditions(self) -> list:
        """Expressions positive iff the loop settles within the horizon its metrics sum over."""

    def stability_matrices(self) -> dict:
        """Matrices whose eigenvalues must all be stable, by name; the closed loop first."""

    def numeric_state_matrix(self) -> "np.ndarray | None":
        """The state matrix's numbers as a float array, or None for a loop of symbols
        (evaluated once per loop: the pole metrics and the spectral radius read it)."""


class FrequencyLoop(Protocol):
    """:attr:`Capability.FREQUENCY_RESPONSE`: responses of the closed loop over frequency,
    at s = jω, or at z = e^{jωT} up to π/T for a sampled loop; withdrawn when
    ``frequency_band`` is None.

    Attributes
    ----------
    frequency_band : (float, float) or None
        (low, high) [rad/s], numbers, containing every corner of the loop for any tunable
        in its box (above π/T_min for a sampled loop).
    """

    frequency_band: tuple[float, float] | None

    def frequency_response(self, omega: Expr) -> Complex:
        """Re and Im of position/reference T at ω [rad/s]."""

    def error_response(self, omega: Expr) -> Complex:
        """Re and Im of error/reference 1 − T at ω [rad/s], exact at low ω."""

    def sensitivity_response(self, omega: Expr) -> Complex:
        """Re and Im of the feedback's S = 1/(1 + L) at ω [rad/s]."""

    def dc_gain(self) -> Expr:
        """T at ω = 0 [1]."""


class OpenLoop(FrequencyLoop, Protocol):
    """:attr:`Capability.OPEN_LOOP`: the loop opened at the position error; withdrawn with
    :attr:`Capability.FREQUENCY_RESPONSE`."""

    def open_loop_response(self, omega: Expr) -> Complex:
        """Re and Im of L at ω [rad/s]."""


class VelocityConstantLoop(Protocol):
    """:attr:`Capability.VELOCITY_CONSTANT`: the loop is type 1 and has a finite C_v."""

    velocity_constant: Expr  # C_v = lim s·L(s) [1/s] (Koren eq 5; Bhatia Ch. IV eq 2)


class StepErrorLoop(Protocol):
    """:attr:`Capability.EXACT_STEP_ERROR`: exact IAE [m·s], ISE [m²·s] and ITAE [m·s²]
    after a unit position step, smooth in the tunables; withdrawn when
    ``has_exact_step_error`` is False (a sampled drive without intersample model)."""

    has_exact_step_error: bool
    step_error_integrals: StepIntegrals


class NumericTransferLoop(Protocol):
    """:attr:`Capability.NUMERIC_TRANSFER`: the loop's transfer functions as float
    polynomials (a loop of numbers), for responses evaluated exactly on a tuned design.

    Attributes
    ----------
    open_numerator, open_denominator : list of Expr
        L(s) = position/position error, highest power first.
    load_numerator : list of Expr or None
        Position per load torque over the characteristic polynomial, or None.
    """

    open_numerator: list
    open_denominator: list
    load_numerator: list | None

    def numeric_transfer(self, output: str = "position", input: str = "reference") -> tuple:
        """(numerator, denominator) float arrays of ``output`` (position, error) per
        ``input`` (reference, load)."""


class LoadLoop(NumericTransferLoop, Protocol):
    """:attr:`Capability.LOAD_INPUT`: a load-torque input (``load_numerator``); withdrawn
    when ``load_numerator`` is None."""


class LoopGainLoop(Protocol):
    """:attr:`Capability.LOOP_GAIN_PRODUCT`; withdrawn when ``loop_gain_product`` is None."""

    loop_gain_product: Expr | None  # |G K'_v K'_p| [1/s] (Bhatia Ch. IV eq 1)


class SampleHorizonLoop(Protocol):
    """:attr:`Capability.SAMPLE_HORIZON`: a sampled loop that sums step responses sample by
    sample over ``horizon`` [s] at periods down to ``period_min`` [s]."""

    horizon: float
    period_min: float
    horizon_samples: int  # samples this loop sums (HorizonError above the limit)
    symbolic_horizon_samples: int  # the same for the loop built on symbols


class HeldCommandLoop(Protocol):
    """:attr:`Capability.HELD_COMMAND`: Koren's sampled loop (an integrator-lag drive behind
    a ZOH), whose held command and numbers give exact responses between samples.

    Attributes
    ----------
    input_matrix : Expr
        Γ of state(k+1) = Φ state(k) + Γ r(k) (Φ the ``state_matrix``).
    plant : IntegratorLag or Integrator
        The drive behind the hold; its ``time_constant`` τ [s], or None for 1/s.
    hold_input : (Expr, Expr)
        (k_x, k_r): the command held over a period is k_x·state + k_r·r.
    """

    input_matrix: Expr
    plant: IntegratorLag | Integrator
    hold_input: tuple

    def numeric_hold(self) -> tuple:
        """(Φ, Γ, k_x, k_r, T, τ) as floats (TypeError for a loop of symbols)."""


class PulseSimulation(Protocol):
    """:attr:`Capability.PULSE_SIMULATION`: an exact, discrete, nonlinear simulation
    (Tian's V-F transformation); metrics read its ``response``."""

    command: PulseInput
    input_kind: str  # step, ramp or sine
    motor: MotorCharacteristic | None
    response: PulseResponse
    horizon: float  # simulated time [s]

    def settled(self) -> bool:
        """Whether the simulated response came to rest (or tracks without saturating)."""

    def stability(self) -> dict:
        """The result's stability block."""


#: each capability's protocol: the members a loop that offers it has
PROTOCOLS: dict[Capability, type] = {
    Capability.LINEAR: LinearDynamics,
    Capability.FREQUENCY_RESPONSE: FrequencyLoop,
    Capability.OPEN_LOOP: OpenLoop,
    Capability.VELOCITY_CONSTANT: VelocityConstantLoop,
    Capability.EXACT_STEP_ERROR: StepErrorLoop,
    Capability.NUMERIC_TRANSFER: NumericTransferLoop,
    Capability.LOAD_INPUT: LoadLoop,
    Capability.LOOP_GAIN_PRODUCT: LoopGainLoop,
    Capability.SAMPLE_HORIZON: SampleHorizonLoop,
    Capability.HELD_COMMAND: HeldCommandLoop,
    Capability.PULSE_SIMULATION: PulseSimulation,
}

#: capabilities a loop's data may withdraw although its class declares them: the test
#: that the loop still offers it
WITHDRAWN: dict[Capability, Callable[[Any], bool]] = {
    Capability.FREQUENCY_RESPONSE: lambda loop: loop.frequency_band is not None,
    Capability.OPEN_LOOP: lambda loop: loop.frequency_band is not None,
    Capability.EXACT_STEP_ERROR: lambda loop: bool(loop.has_exact_step_error),
    Capability.LOAD_INPUT: lambda loop: loop.load_numerator is not None,
    Capability.LOOP_GAIN_PRODUCT: lambda loop: loop.loop_gain_product is not None,
}


class DeclaredCapabilities:
    """The shared :meth:`Loop.offers` of the loop classes: ``capability`` is in the class's
    ``capabilities`` and the loop's data does not withdraw it (:data:`WITHDRAWN`)."""

    capabilities: ClassVar[frozenset[Capability]] = frozenset()
    #: the names of the class's :class:`feedtune.loops.loop.EmbeddedNumber` fields
    embedded_fields: ClassVar[tuple[str, ...]] = ()

    def offers(self, capability: Capability) -> bool:
        if capability not in self.capabilities:
            return False
        still = WITHDRAWN.get(capability)
        return still is None or still(self)

    def embedded_reads(self) -> frozenset[str] | None:
        """The names of the embedded numbers (``embedded_fields``: numbers that may shape
        the loop's graph, such as a horizon) read so far, or None for a loop that records
        none (every number it holds may then shape its graph)."""
        if not self.embedded_fields:
            return None
        return frozenset(self.__dict__.get("_embedded_reads", ()))


class Plant(Protocol):
    """What every plant offers (``feedtune.plants.PLANTS``): its spec model, its tunables
    and its loop.

    Attributes
    ----------
    Params : type
        The pydantic model of the spec's ``plant`` section.
    position_unit : str
        Unit of the loop's position: ``m`` (a linear axis) or ``rad`` (a rotary one).
    """

    Params: ClassVar[type]
    position_unit: str

    def tunables(self) -> dict:
        """The tunable parameters by name: :class:`feedtune.plants.base.Tunable`, with units
        and default bounds (not imported here: a metric imports this module, never a plant)."""

    def loop(self, values: Mapping[str, Expr], box: Mapping[str, tuple[float, float]],
             horizon_scale: float = 1.0) -> Loop:
        """The closed loop at ``values`` (expressions or numbers per tunable), for the box
        of the tunables [their units]; ``horizon_scale`` lengthens summed step responses."""

    def numbers(self) -> dict[str, float]:
        """Plant numbers the NLP takes as parameters, as fixed tunables are (defaults in
        :class:`feedtune.plants.base.Plant`)."""

    def structure(self, box: Mapping[str, tuple[float, float]],
                  horizon_scale: float = 1.0) -> str:
        """What the loop's graph embeds as constants: equal structures build equal graphs."""

    def not_tunable(self) -> dict[str, str]:
        """Tunables this configuration fixes, each with the reason a spec may not free it."""
