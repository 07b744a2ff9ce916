"""Bhatia's rotary electro-hydraulic drive for the validator, from App. A2/A3 (Merritt §6.2).

Torque motor: x_v = K_s/(1 + s/ω_r) · u, optionally times the armature mode
1/(s²/ω_o² + 2ξ_o s/ω_o + 1) [m per V]; valve-controlled motor:

    (s²/ω_n² + 2ξs/ω_n + 1) θ̇ = (K_q/D_m) x_v − (K_ce/D_m²)(1 + V_t s/(4β_e K_ce)) T_L,

ω_n = √(4β_e D_m²/(V_t J_t)), ξ = (K_ce/D_m)√(β_e J_t/V_t) + (B_m/(4D_m))√(V_t/(β_e J_t))
unless given. The motor is written in observable canonical form with both inputs, the
torque motor as a block in series: a state-space Block (u, T_L) → θ̇ [rad/s].
"""

from __future__ import annotations

import math

import numpy as np

from feedtune.validate.cascade import Block, CascadeModel, siso


def motor_block(plant: dict) -> Block:
    """(x_v, T_L) → θ̇ of the valve-controlled motor (App. A2)."""
    be, vt, jt, dm = (plant.get(k) for k in ("bulk_modulus", "total_volume", "inertia",
                                              "displacement"))
    kce, bm = plant.get("leakage_coefficient"), plant.get("viscous_damping", 0.0)
    wn = plant.get("hydraulic_natural_frequency") or math.sqrt(4 * be * dm**2 / (vt * jt))
    zeta = plant.get("hydraulic_damping")
    if zeta is None:
        zeta = kce / dm * math.sqrt(be * jt / vt) + bm / (4 * dm) * math.sqrt(vt / (be * jt))
    a = np.array([[-2 * zeta * wn, 1.0], [-wn**2, 0.0]])
    b = np.zeros((2, 2))
    b[1, 0] = wn**2 * plant["flow_gain"] / dm
    if has_load_path(plant):
        b[0, 1] = -wn**2 * vt / (4 * be * dm**2)  # the s-term of the load numerator
        b[1, 1] = -wn**2 * kce / dm**2
    return Block(a, b, np.array([[1.0, 0.0]]), np.zeros((1, 2)))


def has_load_path(plant: dict) -> bool:
    return all(plant.get(k) is not None for k in ("leakage_coefficient", "total_volume",
                                                   "bulk_modulus"))


def drive_block(plant: dict) -> Block:
    """(u, T_L) → θ̇: the torque motor (App. A3) in series with the motor."""
    den = [plant["torque_motor_time_constant"], 1.0]
    if plant.get("torque_motor_natural_frequency") is not None:
        wo, zo = plant["torque_motor_natural_frequency"], plant.get("torque_motor_damping", 0.5)
        den = np.polymul(den, [1 / wo**2, 2 * zo / wo, 1.0])
    torque_motor = siso([plant["torque_motor_gain"]], den)
    motor = motor_block(plant)
    t, m = torque_motor.order, motor.order
    a = np.zeros((t + m, t + m))
    a[:t, :t] = torque_motor.a
    a[t:, t:] = motor.a
    a[t:, :t] = np.outer(motor.b[:, 0], torque_motor.c[0])
    b = np.zeros((t + m, 2))
    b[:t, 0] = torque_motor.b[:, 0]
    b[t:, 1] = motor.b[:, 1]
    c = np.concatenate([np.zeros(t), motor.c[0]]).reshape(1, -1)
    return Block(a, b, c, np.zeros((1, 2)))


class HydraulicRotaryModel(CascadeModel):
    """Validator model of ``hydraulic_rotary`` (Bhatia Fig 33)."""

    @classmethod
    def from_result(cls, plant: dict, tuned: dict, stability: dict | None = None) -> "HydraulicRotaryModel":
        return cls.from_parts(drive_block(plant), plant, tuned, has_load_path(plant))
