"""Controller structures of a user-defined loop: P, PI, PID, a series compensator, a notch.

Each controller is C(s) = gain · numerator(s)/denominator(s) (highest power first), the
coefficients expressions of its tunables, named ``<loop>_controller.<constant>``:

* ``p``:   C = k_p;
* ``pi``:  C = k_p (1 + 1/(T_i s)) = k_p (T_i s + 1)/(T_i s);
* ``pid``: C = k_p (1 + 1/(T_i s) + T_d s/(T_d s/N + 1)), the derivative filtered at
  N/T_d (a filter time constant τ_f = T_d/N; N = 2 … 20 usual)
  (Åström & Hägglund, *Advanced PID Control*, 2006, §3.1 eq 3.1, §3.3 the filtered
  derivative);

in the standard (ideal) form servo drives use (k_p and the integral time T_i, as a drive's
"Kp, Tn"): the corners 1/T_i and 1/T_d are time constants, bounded as the compensators'
are, and k_p is a loop gain of its own (Bhatia's K' for a P controller).

times, optionally, Bhatia's lag or lag-lead (:mod:`feedtune.plants.compensator`, reused:
tunables ``<loop>_compensator.tau1`` …) and a notch at ω_z with pole damping ζ and depth
δ (the gain at ω_z),

    N(s) = (s² + 2δζω_z s + ω_z²)/(s² + 2ζω_z s + ω_z²),      tunables notch.frequency,
                                                              notch.width, notch.depth.

Every tunable is positive (the tuner works on logarithms). The gain k_p is kept apart
so that a P controller with a compensator closes exactly as Bhatia's K'·Gc (:func:`feedtune.plants.cascade.close_loops`).

References
----------
K. J. Åström, T. Hägglund, "Advanced PID Control", ISA, 2006, §3.3 (the filtered
derivative), §12.5 (notch filters for resonant drives).
S. Bhatia, "Feed drive design for numerically controlled machine tools", M.S. thesis,
University of Missouri–Rolla, 1971, Ch. IV E–F (K'_p, K'_v and the lag-lead).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, Mapping

from feedtune.loops import linalg
from feedtune.plants.base import Tunable
from feedtune.plants.compensator import (CompensatorKind, compensator_polynomials,
                                         compensator_tunables)

Law = Literal["p", "pi", "pid"]

#: default bounds: wide, since a user's drive may be scaled in any unit; narrow them in
#: the spec (the first multistart point is the geometric middle of the box)
GAIN_BOUNDS = (1e-2, 1e3)
TIME_BOUNDS = (1e-4, 10.0)  # T_i, T_d [s], as the compensators' τ (compensator.py)
FILTER_BOUNDS = (1.0, 100.0)  # N [1]: the derivative gain at high frequency is k_p(1 + N)
NOTCH_FREQUENCY_BOUNDS = (1.0, 1e5)  # ω_z [rad/s]
NOTCH_WIDTH_BOUNDS = (0.01, 1.0)  # ζ [1]
NOTCH_DEPTH_BOUNDS = (1e-3, 1.0)  # δ [1], the gain at ω_z


@dataclass(frozen=True)
class Controller:
    """C(s) = gain·numerator/denominator, the gain k_p (Bhatia's K', Ch. IV eq 1)."""

    gain: object
    numerator: list
    denominator: list


@dataclass(frozen=True)
class Structure:
    """One loop's controller: its law, series compensator and whether it holds the notch."""

    law: Law
    compensator: CompensatorKind = "none"
    notch: bool = False


def controller_tunables(loop: str, structure: Structure, kp_unit: str) -> dict[str, Tunable]:
    """Tunables of the ``loop`` (``position`` or ``velocity``) controller; ``kp_unit``: what
    the loop commands per unit of the error it reads."""
    prefix = f"{loop}_controller"
    tunables = {f"{prefix}.kp": Tunable(kp_unit, f"Proportional gain k_p of the {loop} loop "
                                                 f"[{kp_unit}]", *GAIN_BOUNDS)}
    if structure.law in ("pi", "pid"):
        tunables[f"{prefix}.ti"] = Tunable(
            "s", f"Integral time T_i of the {loop} loop: k_p/(T_i s) [s]", *TIME_BOUNDS)
    if structure.law == "pid":
        tunables[f"{prefix}.td"] = Tunable(
            "s", f"Derivative time T_d of the {loop} loop: k_p T_d s/(T_d s/N + 1) [s]",
            *TIME_BOUNDS)
        tunables[f"{prefix}.n"] = Tunable(
            "1", f"Derivative filter ratio N of the {loop} loop: τ_f = T_d/N [1]",
            *FILTER_BOUNDS)
    tunables.update(compensator_tunables(f"{loop}_compensator", structure.compensator,
                                         f"{loop} loop"))
    if structure.notch:
        tunables.update({
            "notch.frequency": Tunable("rad/s", "Notch frequency ω_z (in the loop plant.notch "
                                                "names) [rad/s]", *NOTCH_FREQUENCY_BOUNDS),
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
        numerator, denominator = [1], [1]
    else:
        ti = values[f"{prefix}.ti"]
        if structure.law == "pi":
            numerator, denominator = [ti, 1], [ti, 0]
        else:  # (T_i s(τ_f s + 1) + (τ_f s + 1) + T_i T_d s²)/(T_i s(τ_f s + 1))
            td = values[f"{prefix}.td"]
            tf = td / values[f"{prefix}.n"]
            numerator = [ti * tf + ti * td, ti + tf, 1]
            denominator = [ti * tf, ti, 0]
    n_c, d_c = compensator_polynomials(f"{loop}_compensator", structure.compensator, values)
    numerator, denominator = linalg.poly_mul(numerator, n_c), linalg.poly_mul(denominator, d_c)
    if structure.notch:
        n_n, d_n = notch_polynomials(values)
        numerator, denominator = linalg.poly_mul(numerator, n_n), linalg.poly_mul(denominator, d_n)
    return Controller(kp, numerator, denominator)


def notch_polynomials(values: Mapping[str, object]) -> tuple[list, list]:
    """(s² + 2δζω s + ω², s² + 2ζω s + ω²) of the notch (module docstring)."""
    w, zeta, depth = values["notch.frequency"], values["notch.width"], values["notch.depth"]
    return [1, 2 * depth * zeta * w, w**2], [1, 2 * zeta * w, w**2]


def corners(box: Mapping[str, tuple[float, float]]) -> list[float]:
    """Frequencies [rad/s] where a controller in ``box`` can have a corner: 1/T_i, 1/T_d
    and N/T_d at the ends of their boxes, and the notch frequency's box."""
    out = []
    for loop in ("position", "velocity"):
        prefix = f"{loop}_controller"
        for constant in ("ti", "td"):
            lo, hi = box.get(f"{prefix}.{constant}", (math.inf, math.inf))
            out += [1 / hi, 1 / lo]
        if f"{prefix}.n" in box:
            out.append(box[f"{prefix}.n"][1] / box[f"{prefix}.td"][0])
    if "notch.frequency" in box:
        out += list(box["notch.frequency"])
    return out
