"""Closing Bhatia's two-loop cascade (Fig 18/33) from polynomials, for any drive.

A drive gives its velocity per volt G(s) = n_g/(d_a·d_b) [rad/(s·V)], where the load
torque reaches the velocity through the factor d_b only: θ̇ = G·u − (n_l/d_b)·T_L. The
velocity loop (gain K'_v, compensator Gc_v) and the position loop (gain K'_p,
compensator Gc_p) are closed by unity feedback; the result is a :class:`TransferLoop`.

References
----------
S. Bhatia, "Feed drive design for numerically controlled machine tools", M.S. thesis,
University of Missouri–Rolla, 1971, Ch. IV, Figs 18, 29, 33.
"""

from __future__ import annotations

from typing import Mapping

from feedtune import linalg
from feedtune.loop import Drive, TransferLoop
from feedtune.plants.compensator import CompensatorKind, compensator_polynomials


def cascade_loop(n_g: list, d_a: list, d_b: list, load: list | None, values: Mapping[str, object],
                 velocity_compensator: CompensatorKind, position_compensator: CompensatorKind,
                 stable_velocity_loop: bool, frequency_band: tuple) -> TransferLoop:
    """The closed cascade at ``values`` (``position_gain``, ``velocity_gain``, compensators).

    Characteristic polynomial s·d_cp·(d_cv d_a d_b + K'_v n_cv n_g) + K'_p K'_v n_cp n_cv n_g;
    position per load torque −n_l·d_a·d_cv·d_cp over it (``load`` = n_l, or None).
    """
    kp, kv = values["position_gain"], values["velocity_gain"]
    d_g = linalg.poly_mul(d_a, d_b)
    n_cv, d_cv = compensator_polynomials("velocity_compensator", velocity_compensator, values)
    n_cp, d_cp = compensator_polynomials("position_compensator", position_compensator, values)
    forward = linalg.poly_scale(linalg.poly_mul(n_cv, n_g), kv)  # K'_v Gc_v G, numerator
    inner = linalg.poly_add(linalg.poly_mul(d_cv, d_g), forward)
    load_numerator = None
    if load is not None:
        load_numerator = linalg.poly_scale(
            linalg.poly_mul(linalg.poly_mul(load, d_a), linalg.poly_mul(d_cv, d_cp)), -1)
    return TransferLoop(
        open_numerator=linalg.poly_scale(linalg.poly_mul(n_cp, forward), kp),
        open_denominator=linalg.poly_mul(linalg.poly_mul(d_cp, inner), [1, 0]),
        load_numerator=load_numerator,
        inner_characteristic=inner if stable_velocity_loop else None,
        loop_gain_product=kp * kv * n_g[-1] / d_g[-1],  # Bhatia's |G(0) K'_v K'_p|
        frequency_band=frequency_band,
        drive=Drive())


def compensator_corners(box: Mapping[str, tuple[float, float]]) -> list[float]:
    """1/τ [rad/s] at both ends of every compensator time constant's box."""
    corners = []
    for name, (lo, hi) in box.items():
        if ".tau" in name:
            corners += [1 / hi, 1 / lo]
    return corners
