"""Bhatia's Ward-Leonard drive for the validator, from the machine equations of App. B:

    L_fg i_f' = u − R_fg i_f,                E_a = K'_c i_f            (eq 3)
    L_a i_a'  = E_a − k_b θ̇ − R_a i_a                                 (eq 1)
    J_t θ̈    = k_t i_a − B_m θ̇ − T_L                                  (eq 2)

as a state-space Block (u, T_L) → θ̇ with states [i_f, i_a, θ̇]; with L_a = 0 the armature
current is algebraic, i_a = (E_a − k_b θ̇)/R_a, and the state is [i_f, θ̇].
"""

from __future__ import annotations

import numpy as np

from feedtune.validate.cascade import Block, CascadeModel


def drive_block(plant: dict) -> Block:
    rf, lf, kc = (plant[k] for k in ("generator_field_resistance", "generator_field_inductance",
                                     "generator_gain"))
    ra, la = plant["armature_resistance"], plant["armature_inductance"]
    kt, kb, jt = plant["torque_constant"], plant["back_emf_constant"], plant["inertia"]
    bm = plant.get("viscous_damping", 0.0)
    if la > 0:
        a = np.array([[-rf / lf, 0.0, 0.0],
                      [kc / la, -ra / la, -kb / la],
                      [0.0, kt / jt, -bm / jt]])
        b = np.array([[1 / lf, 0.0], [0.0, 0.0], [0.0, -1 / jt]])
    else:
        a = np.array([[-rf / lf, 0.0],
                      [kt * kc / (ra * jt), -(bm + kt * kb / ra) / jt]])
        b = np.array([[1 / lf, 0.0], [0.0, -1 / jt]])
    c = np.zeros((1, a.shape[0]))
    c[0, -1] = 1.0
    return Block(a, b, c, np.zeros((1, 2)))


class WardLeonardModel(CascadeModel):
    """Validator model of ``ward_leonard`` (Bhatia Figs 13, 43, 18)."""

    @classmethod
    def from_result(cls, plant: dict, tuned: dict, stability: dict | None = None) -> "WardLeonardModel":
        return cls.from_parts(drive_block(plant), plant, tuned, has_load=True)
