"""Bhatia's rotary electro-hydraulic feed drive: torque motor, servo valve, hydraulic motor.

Block diagram of Figs 16, 18 and 33, unity feedback as in Fig 18: the position error
θ_i − θ_o [rad], times K'_p [1/s] and the position compensator, is a velocity command;
the velocity error, times K'_v [V·s/rad] and the velocity compensator, drives the torque
motor K_s/(1 + s/ω_r) [m/V] (optionally with its armature mode ω_o, ξ_o; App. A3), whose
spool displacement x_v drives the valve-controlled motor (App. A2)

    θ_o = [(K_q/D_m) x_v − (K_ce/D_m²)(1 + V_t s/(4β_e K_ce)) T_L] / (s(s²/ω_n² + 2ξs/ω_n + 1)),

with ω_n = √(4β_e D_m²/(V_t J_t)) and ξ = (K_ce/D_m)√(β_e J_t/V_t) + (B_m/(4D_m))√(V_t/(β_e J_t))
unless ω_n and ξ are given (Bhatia uses measured-like ω_n = 75 rad/s, ξ = 0.5). The load
torque T_L [N·m] enters as a disturbance when K_ce, V_t and β_e are known.

SI units throughout: the Bhatia example converts his inch-pound data once.

References
----------
S. Bhatia, "Feed drive design for numerically controlled machine tools", M.S. thesis,
University of Missouri–Rolla, 1971, Ch. III F, IV; App. A2, A3; Figs 16, 18, 20, 29, 33.
H. E. Merritt, "Hydraulic Control Systems", Wiley, 1967, §6.2 (the load-torque term
K_ce/D_m², misprinted K_ce/D_m in Bhatia's App. A2; see docs/errata.md).
"""

from __future__ import annotations

import json
from typing import Literal, Mapping

from pydantic import Field, NonNegativeFloat, PositiveFloat, model_validator

from feedtune.loops import linalg
from feedtune.loops.loop import TransferLoop
from feedtune.plants.base import Plant, Tunable
from feedtune.plants.cascade import cascade_loop, compensator_corners
from feedtune.plants.compensator import CompensatorKind, compensator_tunables
from feedtune.schema.model import SpecModel


class HydraulicRotaryParams(SpecModel):
    """Bhatia 1971, Fig 16 / Fig 33, in SI units."""

    type: Literal["hydraulic_rotary"]
    torque_motor_gain: PositiveFloat = Field(
        description="Torque-motor (servo-valve) gain K_s: spool displacement per volt [m/V] "
                    "(App. A3; Bhatia: 10 in/V = 0.254 m/V)")
    torque_motor_time_constant: PositiveFloat = Field(
        description="Torque-motor time constant 1/ω_r [s] (App. A3; Bhatia's tables use "
                    "0.01 s, printed 0.0105 s, see docs/errata.md)")
    torque_motor_natural_frequency: PositiveFloat | None = Field(
        None, description="Armature natural frequency ω_o [rad/s] (App. A3); omitted: the "
                          "armature mode is neglected, as Bhatia does for ω_o = 775 rad/s")
    torque_motor_damping: PositiveFloat = Field(
        0.5, description="Armature damping ratio ξ_o [1] (used with ω_o only)")
    flow_gain: PositiveFloat = Field(
        description="Valve flow gain K_q: load flow per spool displacement [m²/s] (App. A2)")
    displacement: PositiveFloat = Field(
        description="Motor volumetric displacement D_m [m³/rad] (App. A2)")
    hydraulic_natural_frequency: PositiveFloat | None = Field(
        None, description="Hydraulic natural frequency ω_n [rad/s]; omitted: computed as "
                          "√(4β_e D_m²/(V_t J_t)) (App. A2, Merritt eq 6-59)")
    hydraulic_damping: PositiveFloat | None = Field(
        None, description="Hydraulic damping ratio ξ [1]; omitted: computed from K_ce, B_m, "
                          "β_e, J_t, V_t (App. A2)")
    bulk_modulus: PositiveFloat | None = Field(
        None, description="Effective bulk modulus of the oil β_e [Pa]")
    total_volume: PositiveFloat | None = Field(
        None, description="Total compressed oil volume V_t of both motor chambers [m³]")
    inertia: PositiveFloat | None = Field(
        None, description="Inertia of motor and load referred to the motor shaft J_t [kg·m²]")
    leakage_coefficient: PositiveFloat | None = Field(
        None, description="Total flow-pressure coefficient K_ce = K_c + C_tm [m³/(s·Pa)]")
    viscous_damping: NonNegativeFloat = Field(
        0.0, description="Viscous damping of motor and load B_m [N·m·s/rad]")
    velocity_compensator: CompensatorKind = Field(
        "none", description="Series compensator of the velocity loop: none, lag "
                            "(1+τ1 s)/(1+τ2 s), or lag_lead (App. C)")
    position_compensator: CompensatorKind = Field(
        "none", description="Series compensator of the position loop: none, lag, or lag_lead")
    stable_velocity_loop: bool = Field(
        True, description="Require the velocity loop to be stable on its own, as Bhatia does "
                          "(Ch. IV: 'both the velocity loop as well as the position loop')")

    @model_validator(mode="after")
    def _hydraulics_known(self):
        missing = []
        if self.hydraulic_natural_frequency is None:
            missing += [f for f in ("bulk_modulus", "total_volume", "inertia")
                        if getattr(self, f) is None]
        if self.hydraulic_damping is None:
            missing += [f for f in ("bulk_modulus", "total_volume", "inertia", "leakage_coefficient")
                        if getattr(self, f) is None and f not in missing]
        if missing:
            raise ValueError("give hydraulic_natural_frequency and hydraulic_damping, or the "
                             "data to compute them; missing: " + ", ".join(missing))
        return self

    def natural_frequency(self) -> float:
        """ω_n [rad/s]: given, or √(4β_e D_m²/(V_t J_t)) (App. A2)."""
        return natural_frequency(self.model_dump())

    def damping(self) -> float:
        """ξ [1]: given, or (K_ce/D_m)√(β_e J_t/V_t) + (B_m/(4D_m))√(V_t/(β_e J_t)) (App. A2)."""
        return damping(self.model_dump())

    def has_load_path(self) -> bool:
        return None not in (self.leakage_coefficient, self.total_volume, self.bulk_modulus)


def natural_frequency(n: Mapping[str, object]):
    """ω_n [rad/s] of the plant numbers ``n`` (by field name; numbers or expressions):
    ``hydraulic_natural_frequency`` when given, else √(4β_e D_m²/(V_t J_t)) (App. A2,
    Merritt eq 6-59)."""
    if n.get("hydraulic_natural_frequency") is not None:
        return n["hydraulic_natural_frequency"]
    return (4 * n["bulk_modulus"] * n["displacement"]**2 / (n["total_volume"] * n["inertia"]))**0.5


def damping(n: Mapping[str, object]):
    """ξ [1] of the plant numbers ``n``: ``hydraulic_damping`` when given, else
    (K_ce/D_m)√(β_e J_t/V_t) + (B_m/(4D_m))√(V_t/(β_e J_t)) (App. A2)."""
    if n.get("hydraulic_damping") is not None:
        return n["hydraulic_damping"]
    be, vt, jt, dm = n["bulk_modulus"], n["total_volume"], n["inertia"], n["displacement"]
    return (n["leakage_coefficient"] / dm * (be * jt / vt)**0.5
            + n.get("viscous_damping", 0.0) / (4 * dm) * (vt / (be * jt))**0.5)


def quadratic(natural_frequency, damping) -> list:
    """s²/ω² + 2ξs/ω + 1, highest power first."""
    w = natural_frequency
    return [1 / w**2, 2 * damping / w, 1]


class HydraulicRotary(Plant):
    """Plant ``hydraulic_rotary``: position loop around a velocity loop (Bhatia Fig 33)."""

    Params = HydraulicRotaryParams
    position_unit = "rad"  # a rotary axis: motor shaft angle

    def __init__(self, params: HydraulicRotaryParams):
        self.params = params

    def tunables(self) -> dict[str, Tunable]:
        p = self.params
        tunables = {
            "position_gain": Tunable("1/s", "Position-loop gain K'_p: velocity command per "
                                            "position error (Fig 18)", 1.0, 1000.0),
            "velocity_gain": Tunable("V·s/rad", "Velocity-loop gain K'_v: torque-motor volts "
                                                "per velocity error (Fig 18)", 0.01, 1000.0),
        }
        tunables.update(compensator_tunables("velocity_compensator", p.velocity_compensator,
                                             "velocity loop"))
        tunables.update(compensator_tunables("position_compensator", p.position_compensator,
                                             "position loop"))
        return tunables

    def numbers(self) -> dict[str, float]:
        """The parameters that enter the loop only through arithmetic, as the spec gives
        them (each in its unit): :meth:`loop` also takes them in ``values`` (as NLP
        parameters, or a robust scenario's values). Which ones are read depends on what is
        given: the computed ω_n and ξ read β_e, V_t, J_t, K_ce, B_m; given ones do not."""
        p = self.params
        names = ["torque_motor_gain", "torque_motor_time_constant", "flow_gain", "displacement"]
        if p.torque_motor_natural_frequency is not None:
            names += ["torque_motor_natural_frequency", "torque_motor_damping"]
        names += (["hydraulic_natural_frequency"] if p.hydraulic_natural_frequency is not None
                  else ["bulk_modulus", "total_volume", "inertia"])
        names += (["hydraulic_damping"] if p.hydraulic_damping is not None
                  else ["bulk_modulus", "total_volume", "inertia", "leakage_coefficient",
                        "viscous_damping"])
        if p.has_load_path():
            names += ["leakage_coefficient", "total_volume", "bulk_modulus"]
        return {name: getattr(p, name) for name in dict.fromkeys(names)}

    def structure(self, box: Mapping[str, tuple[float, float]],
                  horizon_scale: float = 1.0) -> str:
        """The choices, which numbers are given, the box and the frequency band [rad/s]
        the loop's graph embeds (see :meth:`feedtune.plants.base.Plant.structure`)."""
        choices = self.params.model_dump(mode="json", exclude=set(self.numbers()))
        return json.dumps([choices, sorted(self.numbers()),
                           {name: list(bounds) for name, bounds in box.items()},
                           list(self.frequency_band(box))], sort_keys=True)

    def velocity_per_volt(self, numbers: Mapping[str, object] | None = None
                          ) -> tuple[list, list, list]:
        """G(s) = θ̇/e_g [rad/(s·V)] as (numerator, torque-motor and hydraulic denominators),
        of the spec's numbers with each of ``numbers`` (name → number or expression) in its
        place."""
        p = self.params
        n = {**p.model_dump(), **(numbers or {})}
        torque_motor = [n["torque_motor_time_constant"], 1]
        if p.torque_motor_natural_frequency is not None:
            torque_motor = linalg.poly_mul(torque_motor, quadratic(
                n["torque_motor_natural_frequency"], n["torque_motor_damping"]))
        gain = n["torque_motor_gain"] * n["flow_gain"] / n["displacement"]
        return [gain], torque_motor, quadratic(natural_frequency(n), damping(n))

    def loop(self, values: Mapping[str, object], box: Mapping[str, tuple[float, float]],
             horizon_scale: float = 1.0) -> TransferLoop:
        """The closed loop at ``values`` (expressions or numbers per tunable name, and for
        any of :meth:`numbers`, which then replace the spec's own in the arithmetic)."""
        p = self.params
        numbers = {name: values[name] for name in self.numbers() if name in values}
        n_g, d_t, d_h = self.velocity_per_volt(numbers)
        load = None
        if p.has_load_path():  # θ̇ per T_L = −n_l/d_h (App. A2, Merritt)
            n = {**self.numbers(), **numbers}
            kce, dm = n["leakage_coefficient"], n["displacement"]
            load = [kce / dm**2 * n["total_volume"] / (4 * n["bulk_modulus"] * kce), kce / dm**2]
        return cascade_loop(n_g, d_t, d_h, load, values, p.velocity_compensator,
                            p.position_compensator, p.stable_velocity_loop, self.frequency_band(box))

    def frequency_band(self, box: Mapping[str, tuple[float, float]]) -> tuple[float, float]:
        """(low, high) [rad/s]: two decades around every corner the loop can have."""
        p = self.params
        corners = [1 / p.torque_motor_time_constant, p.natural_frequency()]
        if p.torque_motor_natural_frequency is not None:
            corners.append(p.torque_motor_natural_frequency)
        corners += compensator_corners(box)
        lo_k, hi_k = box["position_gain"]
        corners += [lo_k, hi_k]
        return min(corners) / 100, max(corners) * 100
