"""The closed-loop pole measures re-measured from the validator's own model: the slowest
decay rate σ_min = min −Re p [1/s] and the smallest damping ratio ζ_min = min −Re p/|p|
[1] (the ``decay_rate`` and ``pole_damping`` metrics, MATLAB's ``TuningGoal.Poles``).

The poles are the model's (numpy eigenvalues of its own closed loop, written from the
papers); a sampled model's z-plane poles are mapped by s = ln(z)/T on the principal
branch, as MATLAB's and python-control's ``damp`` do, and a pole at z = 0 (a delay
buffer sample) decays at once, so it sets neither measure.
"""

from __future__ import annotations

import numpy as np

from feedtune.validate.model import NotCovered
from feedtune.validate.tolerances import judge

#: |z| below this is a pole at the origin of the z-plane (a delay buffer's sample, whose
#: computed value is rounding, ~1e-17): it decays within one sample
ZERO_POLE = 1e-12


def s_plane(poles: np.ndarray, sampled: bool, period: float | None) -> np.ndarray:
    """s-plane poles [1/s]: ``poles`` themselves, or ln(z)/T of every z-plane pole with
    |z| > ZERO_POLE (T = ``period`` [s])."""
    poles = np.asarray(poles, dtype=complex)
    if sampled:
        return np.log(poles[np.abs(poles) > ZERO_POLE]) / period
    return poles


def decay_rate(s: np.ndarray) -> tuple[float, float]:
    """(σ_min = min −Re p [1/s], |p| [1/s] of the pole that sets it); (∞, ∞) without poles."""
    if not s.size:
        return float("inf"), float("inf")
    k = int(np.argmin(-s.real))
    return float(-s[k].real), float(abs(s[k]))


def pole_damping(s: np.ndarray) -> float:
    """ζ_min = min −Re p/|p| [1]: a real stable pole has 1, a pole at the origin 0; 1
    without poles."""
    if not s.size:
        return 1.0
    size = np.abs(s)
    return float(np.min(np.where(size > 0, -s.real / np.where(size > 0, size, 1.0), 0.0)))


def pole_entries(model, result: dict) -> list[dict]:
    """Entries for the ``decay_rate`` and ``pole_damping`` metrics of ``result``, from the
    poles of ``model``, judged by :func:`feedtune.validate.tolerances.judge`. The decay
    rate is judged on the magnitude |p| of the pole that sets it: an eigenvalue's rounding
    is relative to its own magnitude (the ``poles`` entry's basis)."""
    metrics = [m for m in (result.get("metrics") or {}).values()
               if m["metric"] in ("decay_rate", "pole_damping") and m.get("value") is not None]
    if not metrics:
        return []
    try:
        s = s_plane(model.poles(), model.sampled, model.period)
    except NotCovered:  # a model without poles: these metrics are left out
        return []
    context = model.context()
    entries = []
    for m in metrics:
        if m["metric"] == "decay_rate":
            value, size = decay_rate(s)
            entries.append(judge(m, value, context, (size, "|p| of the slowest-decaying pole")))
        else:
            entries.append(judge(m, pole_damping(s), context))
    return entries
