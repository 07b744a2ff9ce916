"""What ``feedtune identify --model`` can fit: each bundled drive's identifiable constants,
and the ``linear`` plant's transfer function.

Every model is a :class:`~feedtune.measured.fit.Structure` of G(s) = b(s)/(s^k a(s))
e^{−θs} (command → position), the named parameters read from its coefficients, and the
plant block that puts them into a spec. From command and position (or velocity) data
only the transfer function is identifiable; a drive's physical constants enter it in
products and ratios, which are *lumped* here, and the plant block writes them with the
other constants of each product set to 1 (each case below says which). The loop, and so a
tuning, depends only on the transfer function, so it is the same as with the true
constants.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from feedtune.measured.fit import Structure

@dataclass(frozen=True)
class Parameter:
    """A named quantity read from the fitted coefficients."""

    unit: str
    description: str


@dataclass(frozen=True)
class Model:
    """One identifiable model.

    Attributes
    ----------
    structure : Structure
    position_unit : str or None
        The plant's position unit (``m``/``rad``); None: the data's.
    input_unit : str or None
        The command unit the plant's gains assume; None: the data's.
    parameters : callable
        (units) → {name: Parameter}, in the order ``values`` returns them.
    values : callable
        (b, a, θ) → ndarray of the named parameters (b, a ascending, a_0 = 1).
    plant : callable
        (named values, units) → the plant block.
    lumped : str
        What the data cannot separate, and how the block writes it.
    replaced : tuple of str
        Fields of a template plant block (``--like``) that the identified constants make
        meaningless, left out beside the fields the block writes.
    """

    name: str
    structure: Structure
    position_unit: str | None
    input_unit: str | None
    parameters: Callable[[dict], dict[str, Parameter]]
    values: Callable[[np.ndarray, np.ndarray, float], np.ndarray]
    plant: Callable[[dict[str, float], dict], dict]
    lumped: str
    options: dict = field(default_factory=dict)
    replaced: tuple[str, ...] = ()

    def block(self, values: dict[str, float], units: dict, template: dict | None) -> dict:
        """The plant block: the identified constants over ``template``'s other fields
        (its choices: technique, compensators, controllers, BLU, …) when one is given."""
        identified = self.plant(values, units)
        if template is None:
            return identified
        if template.get("type") != identified["type"]:
            raise ValueError(f"the template plant is {template.get('type')!r}, the model "
                             f"{identified['type']!r}")
        kept = {k: v for k, v in template.items() if k not in self.replaced}
        return {**kept, **identified}


def _gain_unit(units: dict) -> str:
    return f"{units['position']}/(s·{units['input']})"


def _coefficient_unit(units: dict, power: int) -> str:
    """Unit of b_j: position/input × s^(j − k)."""
    inp = units["input"]
    inp = f"({inp})" if any(c in inp for c in "·/*") else inp
    if power == 0:
        return f"{units['position']}/{inp}"
    if power > 0:
        return f"{units['position']}·s{'' if power == 1 else f'^{power}'}/{inp}"
    return f"{units['position']}/({inp}·s{'' if power == -1 else f'^{-power}'})"


def _real_and_pair(a: np.ndarray) -> tuple[float, float, float]:
    """A cubic 1 + a1 s + a2 s² + a3 s³ as (1 + T s)(1 + c1 s + c2 s²): (T [s], c1 [s],
    c2 [s²]). With a complex pair the real root is T; with three real roots T is the
    smallest time constant (the data cannot tell which pole is which; the transfer function
    and the loop are the same either way)."""
    roots = np.roots(a[::-1])
    real = np.abs(roots.imag) <= 1e-9 * np.abs(roots)
    # the real root alone; of three, the largest |r| (the smallest time constant −1/r)
    lone = int(np.argmin(np.where(real, roots.real, np.inf))) if real.all() else \
        int(np.flatnonzero(real)[0])
    r1, r2 = np.delete(roots, lone)
    c1 = float(np.real(-(r1 + r2) / (r1 * r2)))
    c2 = float(np.real(1 / (r1 * r2)))
    return float(-1 / roots[lone].real), c1, c2


def software_servo() -> Model:
    """Koren's drive K_m/(s(1 + τs)): velocity gain and time constant."""
    return Model(
        "software_servo", Structure(0, 1, 1, False, True), "m", None,
        lambda units: {
            "velocity_gain": Parameter(_gain_unit(units), "Drive gain K_m: velocity per "
                                       "command at DC (Koren eq 3's K_m; the position loop's "
                                       "K = K_c K_m K_e)"),
            "time_constant": Parameter("s", "Mechanical time constant τ of the loaded drive "
                                            "(Koren eq 3)")},
        lambda b, a, theta: np.array([b[0], a[1]]),
        lambda v, units: {"type": "software_servo", "technique": "reference_pulse",
                          "time_constant": v["time_constant"]},
        "The plant block has only τ: the loop gain K = K_c·K_m·K_e is the tunable "
        "position_gain, so the controller gain to set is K_c = K/(K_m·K_e) with the "
        "velocity_gain K_m identified here. Without --like the technique is reference_pulse.")


def hydraulic_rotary() -> Model:
    """Bhatia's electro-hydraulic drive, K/((1 + τ_r s)(s²/ω_n² + 2ξs/ω_n + 1))/s."""

    def values(b, a, theta):
        tau, c1, c2 = _real_and_pair(a)
        wn = 1 / np.sqrt(c2)
        return np.array([b[0], tau, wn, c1 * wn / 2])

    def plant(v, units):
        return {"type": "hydraulic_rotary", "torque_motor_gain": v["velocity_gain"],
                "torque_motor_time_constant": v["torque_motor_time_constant"],
                "flow_gain": 1.0, "displacement": 1.0,
                "hydraulic_natural_frequency": v["hydraulic_natural_frequency"],
                "hydraulic_damping": v["hydraulic_damping"]}

    return Model(
        "hydraulic_rotary", Structure(0, 3, 1, False, True), "rad", "V",
        lambda units: {
            "velocity_gain": Parameter(_gain_unit(units), "Motor velocity per torque-motor "
                                       "volt at DC, K_s·K_q/D_m (App. A2, A3)"),
            "torque_motor_time_constant": Parameter("s", "Torque-motor time constant 1/ω_r "
                                                         "(App. A3)"),
            "hydraulic_natural_frequency": Parameter("rad/s", "Hydraulic natural frequency "
                                                              "ω_n (App. A2)"),
            "hydraulic_damping": Parameter("1", "Hydraulic damping ratio ξ (App. A2)")},
        values, plant,
        "K_s, K_q and D_m enter only as K_s·K_q/D_m: the block writes it as "
        "torque_motor_gain with flow_gain 1 m²/s and displacement 1 m³/rad. β_e, V_t, J_t, "
        "K_ce and B_m enter only through ω_n and ξ, which the block gives directly; the "
        "load-torque path they would define is not identified (no load-torque data). If "
        "all three poles are real, the fastest is taken as the torque motor.",
        replaced=("torque_motor_natural_frequency", "torque_motor_damping", "bulk_modulus",
                  "total_volume", "inertia", "leakage_coefficient", "viscous_damping"))


def ward_leonard() -> Model:
    """Bhatia's Ward-Leonard drive, K/((1 + τ_fg s)(1 + τ_m s + τ_m τ_a s²))/s."""

    def values(b, a, theta):
        tau, c1, c2 = _real_and_pair(a)
        return np.array([b[0], tau, c1, c2 / c1])

    def plant(v, units):
        return {"type": "ward_leonard", "generator_gain": v["velocity_gain"],
                "generator_field_resistance": 1.0,
                "generator_field_inductance": v["field_time_constant"],
                "armature_resistance": 1.0,
                "armature_inductance": v["armature_time_constant"],
                "torque_constant": 1.0, "back_emf_constant": 1.0,
                "inertia": v["electromechanical_time_constant"], "viscous_damping": 0.0}

    return Model(
        "ward_leonard", Structure(0, 3, 1, False, True), "rad", "V",
        lambda units: {
            "velocity_gain": Parameter(_gain_unit(units), "G(0) = k_t K'_c/(R_fg(R_a B_m + "
                                       "k_t k_b)): motor velocity per field volt at DC "
                                       "(App. B)"),
            "field_time_constant": Parameter("s", "Generator field time constant τ_fg = "
                                                  "L_fg/R_fg (App. B eq 3)"),
            "electromechanical_time_constant": Parameter(
                "s", "τ_m = (R_a J_t + L_a B_m)/(R_a B_m + k_t k_b), the s coefficient of "
                     "the motor's D(s)/D(0) (App. B eqs 1–2)"),
            "armature_time_constant": Parameter(
                "s", "τ_a = R_a L_a J_t/(R_a J_t + L_a B_m), the s² coefficient of D(s)/D(0) "
                     "over τ_m; L_a/R_a when B_m = 0")},
        values, plant,
        "Only G(0), τ_fg and D(s)/D(0) = 1 + τ_m s + τ_m τ_a s² are identifiable; the block "
        "writes them with R_fg = R_a = 1 Ω, k_t = k_b = 1, B_m = 0 (so K'_c = G(0), "
        "L_fg = τ_fg, L_a = τ_a, J_t = τ_m): B_m is lumped into τ_m, τ_a and the gain. If "
        "all three poles are real, the fastest is taken as the field.")


def linear(poles: int, zeros: int, integrators: int, dead_time: bool) -> Model:
    """The ``linear`` plant: b(s)/(s^k a(s)) e^{−θs} of the orders given."""
    n, m, k = poles, zeros, integrators

    def parameters(units):
        out = {}
        for j in range(m + 1):
            out[f"numerator_s{j}"] = Parameter(_coefficient_unit(units, j - k),
                                               f"b_{j}, coefficient of s^{j} in b(s)")
        for i in range(1, n + 1):
            out[f"denominator_s{i}"] = Parameter("s" if i == 1 else f"s^{i}",
                                                 f"a_{i}, coefficient of s^{i} in a(s) (a_0 = 1)")
        if dead_time:
            out["dead_time"] = Parameter("s", "Input dead time θ")
        return out

    def values(b, a, theta):
        return np.concatenate([b, a[1:], [theta] if dead_time else []])

    def plant(v, units):
        b = [v[f"numerator_s{j}"] for j in range(m, -1, -1)]
        a = [v[f"denominator_s{i}"] for i in range(n, 0, -1)] + [1.0] + [0.0] * k
        return {"type": "linear",
                "model": {"type": "transfer_function", "numerator": b, "denominator": a},
                "output_unit": units["position"], "input_unit": units["input"],
                "dead_time": v.get("dead_time", 0.0)}

    return Model(
        "linear", Structure(m, n, k, dead_time, False), None, None, parameters, values, plant,
        "Nothing is lumped: the transfer function is the model.",
        {"poles": n, "zeros": m, "integrators": k, "dead_time": dead_time},
        replaced=("dead_time_samples",))
