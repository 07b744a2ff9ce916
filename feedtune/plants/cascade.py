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

from dataclasses import dataclass
from typing import Mapping

from feedtune.loops import linalg
from feedtune.loops.loop import Drive, TransferLoop
from feedtune.plants.compensator import CompensatorKind, compensator_polynomials


@dataclass(frozen=True)
class Closed:
    """Polynomials of a closed position loop, highest power first.

    ``open_numerator``/``open_denominator``: L(s) = position/position error;
    ``inner``: the velocity loop's characteristic polynomial (None without one);
    ``error_numerator``: the error e = r − y per reference over den L + num L, when a
    velocity feed-forward makes it differ from den L (else None).
    """

    open_numerator: list
    open_denominator: list
    inner: list | None = None
    error_numerator: list | None = None


def close_loops(n_g: list, d_g: list, position: tuple, velocity: tuple | None = None,
                n_x: list | None = None, q: list = (1, 0), feedforward=0) -> Closed:
    """Close a position loop, optionally around a velocity loop, from polynomials.

    The drive's velocity per input is n_g/d_g and its position per input n_x/(q·d_g)
    (``n_x`` = n_g and q = s when the position integrates the velocity, Fig 18). Each
    controller is (gain K, numerator n_c, denominator d_c): C = K n_c/d_c. With a velocity
    loop the characteristic polynomial is q·d_cp·(d_cv d_g + K_v n_cv n_g) + K_p K_v n_cp
    n_cv n_x; without, q·d_cp·d_g + K_p n_cp n_x. A velocity feed-forward k_ff (a number in
    [0, 1], velocity loop only) adds k_ff·s·r to the velocity command: the reference path
    becomes (C_p + k_ff s)·Y/V, the characteristic polynomial is unchanged, and the error
    numerator is q·d_cp·(inner) − k_ff·s·d_cp·K_v n_cv n_x.
    """
    kp, n_cp, d_cp = position
    n_x = n_g if n_x is None else n_x
    if velocity is None:
        to_position, inner = linalg.poly_mul(n_cp, n_x), None
        open_numerator = linalg.poly_scale(to_position, kp)
        open_denominator = linalg.poly_mul(linalg.poly_mul(d_cp, d_g), list(q))
        return Closed(open_numerator, open_denominator)
    kv, n_cv, d_cv = velocity
    forward = linalg.poly_scale(linalg.poly_mul(n_cv, n_g), kv)  # K'_v Gc_v G, numerator
    inner = linalg.poly_add(linalg.poly_mul(d_cv, d_g), forward)
    to_position = forward if n_x is n_g else linalg.poly_scale(linalg.poly_mul(n_cv, n_x), kv)
    open_numerator = linalg.poly_scale(linalg.poly_mul(n_cp, to_position), kp)
    open_denominator = linalg.poly_mul(linalg.poly_mul(d_cp, inner), list(q))
    error_numerator = None
    if feedforward:
        error_numerator = linalg.poly_add(open_denominator, linalg.poly_scale(
            linalg.poly_mul(linalg.poly_mul(d_cp, to_position), [1, 0]), -feedforward))
    return Closed(open_numerator, open_denominator, inner, error_numerator)


def cascade_loop(n_g: list, d_a: list, d_b: list, load: list | None, values: Mapping[str, object],
                 velocity_compensator: CompensatorKind, position_compensator: CompensatorKind,
                 stable_velocity_loop: bool, frequency_band: tuple) -> TransferLoop:
    """The closed cascade at ``values`` (``position_gain``, ``velocity_gain``, compensators).

    Characteristic polynomial s·d_cp·(d_cv d_a d_b + K'_v n_cv n_g) + K'_p K'_v n_cp n_cv n_g
    (:func:`close_loops`); position per load torque −n_l·d_a·d_cv·d_cp over it (``load`` =
    n_l, or None).
    """
    kp, kv = values["position_gain"], values["velocity_gain"]
    d_g = linalg.poly_mul(d_a, d_b)
    n_cv, d_cv = compensator_polynomials("velocity_compensator", velocity_compensator, values)
    n_cp, d_cp = compensator_polynomials("position_compensator", position_compensator, values)
    closed = close_loops(n_g, d_g, (kp, n_cp, d_cp), (kv, n_cv, d_cv))
    load_numerator = None
    if load is not None:
        load_numerator = linalg.poly_scale(
            linalg.poly_mul(linalg.poly_mul(load, d_a), linalg.poly_mul(d_cv, d_cp)), -1)
    return TransferLoop(
        open_numerator=closed.open_numerator,
        open_denominator=closed.open_denominator,
        load_numerator=load_numerator,
        inner_characteristic=closed.inner if stable_velocity_loop else None,
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
