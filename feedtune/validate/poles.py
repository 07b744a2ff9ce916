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

from feedtune.validate.measurements import Measurement, Phase, measure_entries
from feedtune.validate.model import NotCovered

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


def _s_poles(model, cache: dict) -> np.ndarray:
    """The model's s-plane poles, once per result."""
    if "s_poles" not in cache:
        cache["s_poles"] = s_plane(model.poles(), model.sampled, model.period)
    return cache["s_poles"]


def _decay_rate(model, options: dict, reported, cache: dict):
    """σ_min judged on |p| of the pole that sets it: an eigenvalue's rounding is relative
    to its own magnitude (the ``poles`` entry's basis)."""
    value, size = decay_rate(_s_poles(model, cache))
    return value, (size, "|p| of the slowest-decaying pole")


def _has_poles(model, options: dict) -> bool:
    """A model without poles (the pulse generator) measures neither pole metric."""
    try:
        model.poles()
    except NotCovered:
        return False
    return True


#: every model with poles: metric → measurement (after the model's own table)
POLE_MEASUREMENTS: dict[str, Measurement] = {
    "decay_rate": Measurement(_decay_rate, _has_poles),
    "pole_damping": Measurement(lambda m, o, r, c: pole_damping(_s_poles(m, c)), _has_poles),
}


def pole_entries(model, result: dict) -> list[dict]:
    """Entries for the ``decay_rate`` and ``pole_damping`` metrics of ``result``, from the
    poles of ``model`` (:data:`POLE_MEASUREMENTS`), judged by
    :func:`feedtune.validate.tolerances.judge` on the model's context."""
    return measure_entries(model, (Phase(POLE_MEASUREMENTS),), result, lambda: model.context())
