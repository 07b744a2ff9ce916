"""Series compensators of a loop: none, lag (Table 5) or lag-lead (App. C).

* ``lag``: (1 + τ1 s)/(1 + τ2 s) — Bhatia Table 5 (a lag when τ2 > τ1, a lead otherwise);
* ``lag_lead``: (1 + τ1 s)(1 + τ2 s)/(τ1τ2 s² + (τ1 + τ2 + τ12)s + 1) — App. C, Fig 44.

Both have unit DC gain, so they shape the loop without changing its velocity constant.
Their constants are tunables named ``<loop>_compensator.tau1`` etc. Every τ is positive
(the tuner works on logarithms), so τ1 + τ2 + τ12 > τ1 + τ2 and the lag-lead's
denominator is always Hurwitz: the compensator itself is stable and minimum phase.

References
----------
S. Bhatia, "Feed drive design for numerically controlled machine tools", M.S. thesis,
University of Missouri–Rolla, 1971, Ch. IV E–F, Tables 1, 2, 5, 6, App. C.
"""

from __future__ import annotations

from typing import Literal

from feedtune.plants.base import Tunable

CompensatorKind = Literal["none", "lag", "lag_lead"]

#: default bounds of the time constants [s]; wide enough for Bhatia's designs (τ12 = 10 s)
TAU_BOUNDS = (1e-4, 10.0)
TAU12_BOUNDS = (1e-4, 100.0)


def compensator_tunables(prefix: str, kind: CompensatorKind, loop_name: str) -> dict[str, Tunable]:
    """The time constants of a compensator as tunables ``<prefix>.tau1`` … [s]."""
    if kind == "none":
        return {}
    tunables = {
        f"{prefix}.tau1": Tunable("s", f"Compensator time constant τ1 of the {loop_name} "
                                       "(numerator (1 + τ1 s))", *TAU_BOUNDS),
        f"{prefix}.tau2": Tunable("s", f"Compensator time constant τ2 of the {loop_name}"
                                       + (" (denominator (1 + τ2 s))" if kind == "lag" else
                                          " (numerator (1 + τ2 s))"), *TAU_BOUNDS),
    }
    if kind == "lag_lead":
        tunables[f"{prefix}.tau12"] = Tunable(
            "s", f"Lag-lead coupling constant τ12 of the {loop_name}: the denominator is "
                 "τ1τ2 s² + (τ1 + τ2 + τ12)s + 1 (App. C)", *TAU12_BOUNDS)
    return tunables


def compensator_polynomials(prefix: str, kind: CompensatorKind, values) -> tuple[list, list]:
    """(numerator, denominator) of the compensator, highest power first."""
    if kind == "none":
        return [1], [1]
    tau1, tau2 = values[f"{prefix}.tau1"], values[f"{prefix}.tau2"]
    if kind == "lag":
        return [tau1, 1], [tau2, 1]
    tau12 = values[f"{prefix}.tau12"]
    return [tau1 * tau2, tau1 + tau2, 1], [tau1 * tau2, tau1 + tau2 + tau12, 1]
