"""Controller structures of a user-defined loop: P, PI, PID, a series compensator, a notch.

Each controller is C(s) = gain · numerator(s)/denominator(s) (highest power first), the
coefficients expressions of its tunables, named ``<loop>_controller.<constant>``:

* ``p``:   C = k_p;
* ``pi``:  C = k_p + k_i/s = (k_p s + k_i)/s;
* ``pid``: C = k_p + k_i/s + k_d s/(τ_f s + 1), the derivative filtered by τ_f
  (Åström & Hägglund, *Advanced PID Control*, 2006, §3.3, eq 3.12 with T_f = τ_f);

times, optionally, Bhatia's lag or lag-lead (:mod:`feedtune.plants.compensator`, reused:
tunables ``<loop>_compensator.tau1`` …) and a notch at ω_z with pole damping ζ and depth
δ (the gain at ω_z),

    N(s) = (s² + 2δζω_z s + ω_z²)/(s² + 2ζω_z s + ω_z²),      tunables notch.frequency,
                                                              notch.width, notch.depth.

Every tunable is positive (the tuner works on logarithms). The proportional gain k_p is
kept apart as ``gain`` so that a P controller with a compensator closes exactly as
Bhatia's K'·Gc (:func:`feedtune.plants.cascade.close_loops`).

References
----------
K. J. Åström, T. Hägglund, "Advanced PID Control", ISA, 2006, §3.3 (the filtered
derivative), §12.5 (notch filters for resonant drives).
S. Bhatia, "Feed drive design for numerically controlled machine tools", M.S. thesis,
University of Missouri–Rolla, 1971, Ch. IV E–F (K'_p, K'_v and the lag-lead).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, Mapping

from feedtune import linalg
from feedtune.plants.base import Tunable
from feedtune.plants.compensator import (CompensatorKind, compensator_polynomials,
                                         compensator_tunables)

Law = Literal["p", "pi", "pid"]

#: default bounds: wide, since a user's drive may be scaled in any unit; narrow them in
#: the spec (the first multistart point is the geometric middle of the box)
GAIN_BOUNDS = (1e-3, 1e4)
FILTER_BOUNDS = (1e-5, 1.0)  # τ_f [s]
NOTCH_FREQUENCY_BOUNDS = (1.0, 1e5)  # ω_z [rad/s]
NOTCH_WIDTH_BOUNDS = (0.01, 1.0)  # ζ [1]
NOTCH_DEPTH_BOUNDS = (1e-3, 1.0)  # δ [1], the gain at ω_z


@dataclass(frozen=True)
class Controller:
    """C(s) = gain·numerator/denominator; ``proportional``: k_p (Bhatia's K', eq 1)."""

    gain: object
    numerator: list
    denominator: list
    proportional: object
    integrators: int  # poles at s = 0: 1 for PI and PID


@dataclass(frozen=True)
class Structure:
    """One loop's controller: its law, series compensator and whether it holds the notch."""

    law: Law
    compensator: CompensatorKind = "none"
    notch: bool = False


def controller_tunables(loop: str, structure: Structure,
                        units: tuple[str, str, str]) -> dict[str, Tunable]:
    """Tunables of the ``loop`` (``position`` or ``velocity``) controller; ``units``: those
    of k_p, k_i and k_d (what the loop commands per unit of the error it reads)."""
    prefix = f"{loop}_controller"
    kp_unit, ki_unit, kd_unit = units
    tunables = {f"{prefix}.kp": Tunable(kp_unit, f"Proportional gain k_p of the {loop} loop "
                                                 f"[{kp_unit}]", *GAIN_BOUNDS)}
    if structure.law in ("pi", "pid"):
        tunables[f"{prefix}.ki"] = Tunable(
            ki_unit, f"Integral gain k_i of the {loop} loop: k_i/s [{ki_unit}]", *GAIN_BOUNDS)
    if structure.law == "pid":
        tunables[f"{prefix}.kd"] = Tunable(
            kd_unit, f"Derivative gain k_d of the {loop} loop: k_d s/(τ_f s + 1) [{kd_unit}]",
            *GAIN_BOUNDS)
        tunables[f"{prefix}.tf"] = Tunable(
            "s", f"Derivative filter time constant τ_f of the {loop} loop [s]", *FILTER_BOUNDS)
    tunables.update(compensator_tunables(f"{loop}_compensator", structure.compensator,
                                         f"{loop} loop"))
    if structure.notch:
        tunables.update({
            "notch.frequency": Tunable("rad/s", f"Notch frequency ω_z in the {loop} loop "
                                                "[rad/s]", *NOTCH_FREQUENCY_BOUNDS),
            "notch.width": Tunable("1", "Notch pole damping ζ: the width of the notch [1]",
                                   *NOTCH_WIDTH_BOUNDS),
            "notch.depth": Tunable("1", "Notch depth δ: its gain at ω_z (δ < 1 attenuates) "
                                        "[1]", *NOTCH_DEPTH_BOUNDS),
        })
    return tunables


def controller(loop: str, structure: Structure, values: Mapping[str, object]) -> Controller:
    """The ``loop`` controller at ``values`` (numbers or expressions per tunable name)."""
    prefix = f"{loop}_controller"
    kp = values[f"{prefix}.kp"]
    if structure.law == "p":
        gain, numerator, denominator = kp, [1], [1]
    else:
        ki = values[f"{prefix}.ki"]
        if structure.law == "pi":
            gain, numerator, denominator = 1, [kp, ki], [1, 0]
        else:  # (k_p s(τ_f s + 1) + k_i(τ_f s + 1) + k_d s²)/(s(τ_f s + 1))
            kd, tf = values[f"{prefix}.kd"], values[f"{prefix}.tf"]
            gain = 1
            numerator = [kp * tf + kd, kp + ki * tf, ki]
            denominator = [tf, 1, 0]
    n_c, d_c = compensator_polynomials(f"{loop}_compensator", structure.compensator, values)
    numerator, denominator = linalg.poly_mul(numerator, n_c), linalg.poly_mul(denominator, d_c)
    if structure.notch:
        n_n, d_n = notch_polynomials(values)
        numerator, denominator = linalg.poly_mul(numerator, n_n), linalg.poly_mul(denominator, d_n)
    return Controller(gain, numerator, denominator, kp, 0 if structure.law == "p" else 1)


def notch_polynomials(values: Mapping[str, object]) -> tuple[list, list]:
    """(s² + 2δζω s + ω², s² + 2ζω s + ω²) of the notch (module docstring)."""
    w, zeta, depth = values["notch.frequency"], values["notch.width"], values["notch.depth"]
    return [1, 2 * depth * zeta * w, w**2], [1, 2 * zeta * w, w**2]


def corners(box: Mapping[str, tuple[float, float]]) -> list[float]:
    """Frequencies [rad/s] where a controller in ``box`` can have a corner: k_i/k_p,
    k_p/k_d and 1/τ_f at both ends of their boxes, and the notch frequency's box."""
    out = []
    for loop in ("position", "velocity"):
        prefix = f"{loop}_controller"
        kp = box.get(f"{prefix}.kp")
        for name, pick in ((f"{prefix}.ki", lambda k, x: x / k), (f"{prefix}.kd", lambda k, x: k / x)):
            if kp is not None and name in box:
                out += [pick(kp[1], box[name][0]), pick(kp[0], box[name][1])]
        if f"{prefix}.tf" in box:
            out += [1 / box[f"{prefix}.tf"][1], 1 / box[f"{prefix}.tf"][0]]
    if "notch.frequency" in box:
        out += list(box["notch.frequency"])
    return out
