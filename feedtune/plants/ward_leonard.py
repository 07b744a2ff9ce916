"""Bhatia's electric feed drive: Ward-Leonard generator feeding an armature-controlled DC motor.

Block diagram of Figs 13, 43 and 18, unity feedback as in Fig 18: the position error
θ_i − θ_o [rad], times K'_p [1/s] and the position compensator, is a velocity command
[rad/s]; the velocity error, times K'_v [V·s/rad] and the velocity compensator, is the
voltage e [V] across the generator field (App. B eq 3):

    E_a = (K'_c/R_fg)/(1 + τ_fg s) · e,                     τ_fg = L_fg/R_fg,
    I_a = (E_a − K_e I_f θ̇)/(R_a(1 + τ_a s)),              τ_a = L_a/R_a      (App. B eq 1),
    K_m I_f I_a = J_t s²θ + B_m sθ + T_L                                        (App. B eq 2).

I_f is the motor's constant field current, so k_t = K_m I_f [N·m/A] is the torque constant
and k_b = K_e I_f [V·s/rad] the back-emf constant. Eliminating I_a and E_a gives the
velocity per amplifier volt (Bhatia's G(s), Fig 18) and the load path

    θ̇ = [k_t (K'_c/R_fg) e/(1 + τ_fg s) − R_a(1 + τ_a s) T_L] / D(s),
    D(s) = R_a(1 + τ_a s)(J_t s + B_m) + k_t k_b,

so G(s) = k_t K'_c/R_fg / ((1 + τ_fg s) D(s)), third order, with G(0) =
k_t K'_c/(R_fg (R_a B_m + k_t k_b)) [rad/(s·V)].

K'_v is Bhatia's K_v K_g (Ch. IV, Fig 18): the velocity-error amplifier's gain K_v [V/V]
times the tachogenerator constant K_G [V·s/rad] that closes the velocity loop, i.e. field
volts per rad/s of velocity error. K'_p = K_p K_f/K_G [1/s] likewise folds the position
transducer and the tachogenerator into one gain, so the tachogenerator constant itself is
not a parameter: a tuned K'_v divided by K_G is the amplifier gain to set.

Closing both loops (compensators Gc = n_c/d_c, unit DC gain):

    θ = [K'_p K'_v n_g n_cv n_cp θ_i − n_l d_f d_cv d_cp T_L] / char(s),
    char(s) = s d_cp (d_g d_cv + K'_v n_g n_cv) + K'_p K'_v n_g n_cv n_cp,

with G = n_g/d_g, d_g = d_f D, d_f = 1 + τ_fg s and n_l = R_a(1 + τ_a s). Under a constant
load torque the proportional position loop settles with the error
θ_i − θ = R_a T_L/(K'_p K'_v k_t K'_c/R_fg): the motor must carry I_a = T_L/k_t at standstill,
which takes E_a = R_a T_L/k_t from the generator.

SI units throughout.

References
----------
S. Bhatia, "Feed drive design for numerically controlled machine tools", M.S. thesis,
University of Missouri–Rolla, 1971, Ch. III E (Figs 13, 14), Ch. IV (Fig 18, eqs 1–2),
App. B (eqs 1–3, Fig 43), App. C (lag-lead compensator).
W. J. Palm III, "System Dynamics", 3rd ed., McGraw-Hill, 2014, Problem 11.35 (the
generator-fed motor with tachometer feedback whose data examples/ward-leonard-feed-drive.json
uses; see docs/ward-leonard.md).
"""

from __future__ import annotations

import math
from typing import Literal, Mapping

from pydantic import Field, NonNegativeFloat, PositiveFloat, model_validator

from feedtune.loops import linalg
from feedtune.loops.loop import TransferLoop
from feedtune.plants.base import Plant, Tunable
from feedtune.plants.cascade import cascade_loop, compensator_corners
from feedtune.plants.compensator import CompensatorKind, compensator_tunables
from feedtune.schema.model import SpecModel

#: largest ratio torque constant / back-emf constant (or its inverse) accepted; in SI units
#: the two are equal for a lossless machine, so a factor beyond this is a unit slip
#: (V/krpm, lb·in/A) rather than a machine
CONSTANT_RATIO_LIMIT = 2.0


class WardLeonardParams(SpecModel):
    """Bhatia 1971, App. B / Fig 43, in SI units."""

    type: Literal["ward_leonard"]
    generator_gain: PositiveFloat = Field(
        description="Generator constant K'_c: generated armature emf per generator field "
                    "current at the set's constant speed [V/A] (App. B eq 3)")
    generator_field_resistance: PositiveFloat = Field(
        description="Resistance R_fg of the generator field winding, amplifier output "
                    "resistance included [Ω] (App. B eq 3)")
    generator_field_inductance: PositiveFloat = Field(
        description="Inductance L_fg of the generator field winding [H]; τ_fg = L_fg/R_fg "
                    "(App. B eq 3)")
    armature_resistance: PositiveFloat = Field(
        description="Resistance R_a of the armature loop: generator and motor armatures, "
                    "brushes and interpoles in series [Ω] (App. B eq 1)")
    armature_inductance: NonNegativeFloat = Field(
        description="Inductance L_a of the armature loop, both machines [H]; τ_a = L_a/R_a; "
                    "0 neglects it (the drive is then second order) (App. B eq 1)")
    torque_constant: PositiveFloat = Field(
        description="Motor torque constant k_t = K_m I_f: torque per armature current at "
                    "the constant motor field current I_f [N·m/A] (App. B eq 2)")
    back_emf_constant: PositiveFloat = Field(
        description="Motor back-emf constant k_b = K_e I_f: armature emf per shaft speed "
                    "[V·s/rad]; equal to torque_constant in SI units for an ideal machine "
                    "(App. B eq 1)")
    inertia: PositiveFloat = Field(
        description="Inertia J_t of motor and load referred to the motor shaft [kg·m²] "
                    "(App. B eq 2)")
    viscous_damping: NonNegativeFloat = Field(
        0.0, description="Viscous damping B_m of motor and load referred to the motor shaft "
                         "[N·m·s/rad] (App. B eq 2)")
    velocity_compensator: CompensatorKind = Field(
        "none", description="Series compensator of the velocity loop: none, lag "
                            "(1+τ1 s)/(1+τ2 s), or lag_lead (App. C)")
    position_compensator: CompensatorKind = Field(
        "none", description="Series compensator of the position loop: none, lag, or lag_lead")
    stable_velocity_loop: bool = Field(
        True, description="Require the velocity loop to be stable on its own, as Bhatia does "
                          "(Ch. IV: 'both the velocity loop as well as the position loop')")

    @model_validator(mode="after")
    def _machine_constants_agree(self):
        ratio = self.torque_constant / self.back_emf_constant
        if not 1 / CONSTANT_RATIO_LIMIT <= ratio <= CONSTANT_RATIO_LIMIT:
            raise ValueError(
                f"torque_constant ({self.torque_constant:g} N·m/A) and back_emf_constant "
                f"({self.back_emf_constant:g} V·s/rad) differ by a factor "
                f"{max(ratio, 1 / ratio):.3g}; "
                f"in SI units they are equal for a real machine to within a few per cent, so "
                f"one of them is probably in other units (V/krpm: multiply by 30/(1000π); "
                f"lb·in/A: multiply by 0.11298)")
        return self

    def field_time_constant(self) -> float:
        """τ_fg = L_fg/R_fg [s] (App. B eq 3)."""
        return self.generator_field_inductance / self.generator_field_resistance


class WardLeonard(Plant):
    """Plant ``ward_leonard``: position loop around a tachogenerator velocity loop (Fig 13)."""

    Params = WardLeonardParams
    position_unit = "rad"  # a rotary axis: motor shaft angle

    def __init__(self, params: WardLeonardParams):
        self.params = params
        self._bands: dict[tuple, tuple[float, float]] = {}  # frequency_band per box

    def tunables(self) -> dict[str, Tunable]:
        p = self.params
        tunables = {
            "position_gain": Tunable("1/s", "Position-loop gain K'_p = K_p K_f/K_G: velocity "
                                            "command per position error (Fig 18)", 1.0, 1000.0),
            "velocity_gain": Tunable("V·s/rad", "Velocity-loop gain K'_v = K_v K_G: generator "
                                                "field volts per velocity error, amplifier "
                                                "gain times tachogenerator constant (Fig 18)",
                                     0.01, 1000.0),
        }
        tunables.update(compensator_tunables("velocity_compensator", p.velocity_compensator,
                                             "velocity loop"))
        tunables.update(compensator_tunables("position_compensator", p.position_compensator,
                                             "position loop"))
        return tunables

    def numbers(self) -> dict[str, float]:
        """The parameters that enter the loop only through arithmetic, as the spec gives
        them (each in its unit): :meth:`loop` also takes them in ``values`` (as NLP
        parameters, or a robust scenario's values). All nine machine constants, but L_a
        when it is 0 (it then removes the armature pole: the drive's order)."""
        p = self.params
        names = ["generator_gain", "generator_field_resistance", "generator_field_inductance",
                 "armature_resistance", "armature_inductance", "torque_constant",
                 "back_emf_constant", "inertia", "viscous_damping"]
        return {name: getattr(p, name) for name in names
                if name != "armature_inductance" or p.armature_inductance > 0}

    def not_uncertain(self) -> dict[str, str]:
        """L_a = 0 neglects the armature's pole (a second-order drive, App. B eq 1)."""
        if self.params.armature_inductance > 0:
            return {}
        return {"armature_inductance": "it is 0, which neglects the armature pole and makes "
                                       "the drive second order; give a nonzero nominal L_a "
                                       "[H] to make it uncertain"}

    def uncertainty_problem(self, name: str, low: float, high: float) -> str | None:
        """L_a must stay above 0 over its range: at 0 the drive loses a pole (its order)."""
        if name == "armature_inductance" and low <= 0:
            return (f"the range reaches L_a = {low:g} H, where the armature pole vanishes "
                    "and the drive's order drops; give a smallest value above 0")
        return None

    def velocity_per_volt(self, numbers: Mapping[str, object] | None = None
                          ) -> tuple[list, list, list]:
        """G(s) = θ̇/e [rad/(s·V)] as (numerator, field denominator 1 + τ_fg s, D(s)), of
        the spec's numbers with each of ``numbers`` (name → number or expression) in its
        place (App. B eqs 1-3)."""
        n = {**self.numbers(), **(numbers or {})}
        la = n.get("armature_inductance", 0.0)
        ra, jt, bm = n["armature_resistance"], n["inertia"], n["viscous_damping"]
        rfg = n["generator_field_resistance"]
        d_m = [ra * jt, ra * bm + n["torque_constant"] * n["back_emf_constant"]]
        if self.params.armature_inductance > 0:  # D(s) = (R_a + L_a s)(J_t s + B_m) + k_t k_b
            d_m = [la * jt, la * bm + d_m[0], d_m[1]]
        return ([n["torque_constant"] * n["generator_gain"] / rfg],
                [n["generator_field_inductance"] / rfg, 1], d_m)

    def armature_polynomial(self, numbers: Mapping[str, object] | None = None) -> list:
        """n_l(s) = R_a(1 + τ_a s) = L_a s + R_a [Ω] (the load-torque path of App. B eq 1),
        of the spec's numbers with ``numbers`` in their place."""
        n = {**self.numbers(), **(numbers or {})}
        if self.params.armature_inductance > 0:
            return [n["armature_inductance"], n["armature_resistance"]]
        return [n["armature_resistance"]]

    def dc_velocity_gain(self) -> float:
        """G(0) = k_t (K'_c/R_fg)/(R_a B_m + k_t k_b) [rad/(s·V)]."""
        n_g, d_f, d_m = self.velocity_per_volt()
        return n_g[0] / (d_f[-1] * d_m[-1])

    def loop(self, values: Mapping[str, object], box: Mapping[str, tuple[float, float]],
             horizon_scale: float = 1.0) -> TransferLoop:
        """The closed loop at ``values`` (expressions or numbers per tunable name, and for
        any of :meth:`numbers`, which then replace the spec's own in the arithmetic)."""
        p = self.params
        numbers = {name: values[name] for name in self.numbers() if name in values}
        n_g, d_f, d_m = self.velocity_per_volt(numbers)
        # θ̇ per T_L = −(R_a + L_a s)/D(s) (App. B eqs 1–2)
        return cascade_loop(n_g, d_f, d_m, self.armature_polynomial(numbers), values,
                            p.velocity_compensator,
                            p.position_compensator, p.stable_velocity_loop, self.frequency_band(box))

    def frequency_band(self, box: Mapping[str, tuple[float, float]]) -> tuple[float, float]:
        """(low, high) [rad/s]: two decades around every corner the loop can have.

        Corners: the generator field 1/τ_fg, the roots of D(s) (armature and mechanical
        modes), every compensator constant in the box and the fastest pole a lag-lead can
        have ((τ1 + τ2 + τ12)/(τ1τ2), App. C), every position gain in the box, the smallest
        velocity constant K'_p K'_v G(0)/(1 + K'_v G(0)) (the slow closed-loop pole of a
        low-gain loop), and the largest pole the uncompensated velocity loop can have at
        the top of the K'_v box (Fujiwara's bound on the roots of d_g + K'_v n_g).

        Computed once per box (D(s)'s roots in closed form, :func:`root_moduli`): a loop is built at every point of
        a robust search, a batch's reports and the contract tests' grids.
        """
        key = tuple(sorted(box.items()))
        if key not in self._bands:
            self._bands[key] = self._frequency_band(box)
        return self._bands[key]

    def _frequency_band(self, box: Mapping[str, tuple[float, float]]) -> tuple[float, float]:
        p = self.params
        n_g, d_f, d_m = self.velocity_per_volt()
        if not all(math.isfinite(c) for c in [*n_g, *d_f, *d_m]):
            # e.g. R_a = 9e306 Ω: R_a·B_m is inf, and D(s) has no roots to place the band by
            raise OverflowError("G(s)'s coefficients overflow double precision")
        corners = [1 / p.field_time_constant()]
        corners += [modulus for modulus in root_moduli(d_m) if modulus > 0]
        corners += compensator_corners(box)
        for prefix, kind in (("velocity_compensator", p.velocity_compensator),
                             ("position_compensator", p.position_compensator)):
            if kind == "lag_lead":  # fast pole (τ1 + τ2 + τ12)/(τ1τ2) of App. C's denominator
                t1, t2, t12 = (box[f"{prefix}.{t}"] for t in ("tau1", "tau2", "tau12"))
                corners.append((t1[1] + t2[1] + t12[1]) / (t1[0] * t2[0]))
        corners += list(box["position_gain"])
        kvg_low = box["velocity_gain"][0] * self.dc_velocity_gain()
        corners.append(box["position_gain"][0] * kvg_low / (1 + kvg_low))  # smallest C_v
        inner = linalg.poly_add(linalg.poly_mul(d_f, d_m),
                                linalg.poly_scale(n_g, box["velocity_gain"][1]))
        corners.append(fujiwara_bound(inner))
        return min(corners) / 100, max(corners) * 100


def root_moduli(poly: list) -> list[float]:
    """The moduli [rad/s] of the roots of a_0 s² + a_1 s + a_2 or a_0 s + a_1 (floats, a
    root at 0 included as 0): D(s)'s modes, in closed form without numpy (``feedtune
    validate`` imports none, issue 15). For the quadratic, the larger root's modulus
    (|p| + √(p² − 4q))/2 of s² + p s + q, scaled by max(|p|, √|q|) so that no square
    overflows, and the other's |q| over it; a complex pair's √q. numpy's ``roots`` (the
    eigenvalues of the companion matrix) gives the same up to rounding
    (``tests/unit/test_ward_leonard.py``).

    Raises
    ------
    OverflowError
        When a_k/a_0 leaves double precision (the companion matrix cannot be formed).
    """
    coefficients = list(poly)
    while coefficients and coefficients[0] == 0:
        coefficients.pop(0)
    if len(coefficients) <= 1:
        return []
    lead = coefficients[0]
    monic = [c / lead for c in coefficients[1:]]
    if not all(math.isfinite(c) for c in monic):
        raise OverflowError("D(s)'s roots overflow double precision")
    if len(monic) == 1:
        return [abs(monic[0])]
    p, q = monic
    scale = max(abs(p), math.sqrt(abs(q)))
    if scale == 0:
        return [0.0, 0.0]
    ps, qs = p / scale, q / scale / scale
    discriminant = ps * ps - 4 * qs
    if discriminant < 0:
        return [math.sqrt(q)] * 2
    larger = scale * (abs(ps) + math.sqrt(discriminant)) / 2
    return [larger, abs(q) / larger]


def fujiwara_bound(poly: list) -> float:
    """Upper bound 2·max |a_k/a_0|^(1/k) on the root moduli of a_0 sᵐ + … + a_m (floats)."""
    lead = poly[0]
    m = len(poly) - 1
    terms = [abs(poly[k] / lead) ** (1 / k) for k in range(1, m)]
    terms.append(abs(poly[m] / (2 * lead)) ** (1 / m))
    return 2 * max(terms) if terms else 0.0
