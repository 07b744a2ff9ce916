"""The validator's frequency and step-shape metrics of the sampled-data software servo.

numpy/scipy only, on :class:`feedtune.validate.software_servo.ServoModel` (the drive
discretised by ``expm``, Van Loan), never on :mod:`feedtune.loops.loop`:

* the open loop L(e^{jωT}) = K·z^{−d}·C(zI − Φ)⁻¹Γ (:meth:`ServoModel.open_loop`) and
  H = L/(1 + L) on a logarithmic grid from a thousandth of the slowest closed-loop pole
  (s = ln z / T) up to the Nyquist frequency π/T itself, where the discrete loop's
  responses end;
* ``sensitivity_peak``: sup |1/(1 + L)|, refined as ``m_peak``;
* ``m_peak``: sup |H/H(1)| (at least 1, its value as ω → 0), every local maximum of the
  grid refined by bounded Brent; ``bandwidth``: the lowest ω with |H/H(1)|² = ½ (π/T when
  the gain stays above −3 dB up to Nyquist, the tuner's convention); ``crossover_frequency``
  (|L| = 1) and ``phase_margin`` there; ``gain_margin`` 1/|L| where the unwrapped phase
  first reaches −180°, or at π/T when L(−1) is real negative (the phase of a ZOH loop
  often reaches −180° exactly at Nyquist), else +∞;
* ``overshoot`` and ``settling_time`` (step, continuous time): the position between
  samples from the drive's closed-form free motion under the held command, on SUBSTEPS
  points per sample, then refined by bounded Brent (the peak) and brentq (the last exit
  from the band) on the same motion at any time.

Declared in :data:`MEASUREMENTS` (metric → measurement), which a sampled
``ServoModel`` adds to its table (:mod:`feedtune.validate.measurements`).
"""

from __future__ import annotations

import functools
import math

import numpy as np
from scipy.optimize import brentq, minimize_scalar

from feedtune.validate.measurements import Measurement
from feedtune.validate.model import NotCovered

#: grid [points per decade] and its low end: the slowest s-plane pole / GRID_SPAN
POINTS_PER_DECADE, GRID_SPAN = 200, 1e3
#: sub-steps per sample of the dense step response (the peak and the last exit are then
#: refined on the exact closed-form motion)
SUBSTEPS = 64


@functools.lru_cache(maxsize=8)
def _scan(model) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """(grid, L on it, H on it, H(1)) of a model: ω [rad/s] from the slowest pole /
    GRID_SPAN to π/T, π/T itself the last point; H the model's ``complementary``
    (position/reference, a feed-forward included; ``frequency_response`` gives L and H
    together) and H(z = 1) its ``dc_gain()`` (1 for a type-1 loop). Computed once per
    model (the metrics share it)."""
    z = model.poles().astype(complex)
    speeds = np.abs(np.log(z[np.abs(z) > 1e-12]) / model.period)
    speeds = speeds[speeds > 0]
    nyquist = math.pi / model.period
    low = (float(np.min(speeds)) if speeds.size else nyquist) / GRID_SPAN
    count = int(POINTS_PER_DECADE * math.log10(nyquist / low)) + 2
    grid = np.geomspace(low, nyquist, count)
    grid[-1] = nyquist
    # (L, H) at once: the servo's H is L/(1 + L) of the same L (one solve on the grid, not
    # two), the general sampled loop's its own complementary; the same numbers either way
    open_loop, closed = model.frequency_response(grid)
    return grid, open_loop, closed, model.dc_gain()


def _gain_squared(model, omega: float, dc: float) -> float:
    """|H(e^{jωT})/H(1)|² at one ω [rad/s] (the refinements' calls), ``dc`` = H(1) [1] as
    the caller read it from :func:`_scan` (looked up here, each call hashed the model:
    ≈ 1.5 µs of each of the ≈ 50 calls a sampled spec)."""
    return abs(model.frequency_response_at(omega)[1] / dc) ** 2


def m_peak(model) -> float:
    """sup over 0 ≤ ω ≤ π/T of |H/H(1)| [1]."""
    grid, _, closed, dc = _scan(model)
    g = np.abs(closed / dc) ** 2
    best = max(1.0, float(np.sqrt(np.max(g))))
    padded = np.concatenate([[-np.inf], g, [-np.inf]])
    for i in np.flatnonzero((padded[1:-1] >= padded[:-2]) & (padded[1:-1] >= padded[2:])):
        lo, hi = math.log(grid[max(i - 1, 0)]), math.log(grid[min(i + 1, grid.size - 1)])
        res = minimize_scalar(lambda u: -_gain_squared(model, math.exp(u), dc), bounds=(lo, hi),
                              method="bounded", options={"xatol": 1e-12})
        best = max(best, math.sqrt(-float(res.fun)))
    return best


def sensitivity_peak(model) -> float:
    """M_s = sup over 0 ≤ ω ≤ π/T of |1/(1 + L(e^{jωT}))| [1]; every local maximum of the
    grid above 1 + 1e-9 refined by bounded Brent (|S| sits at 1 to rounding where |L| ≪ 1,
    and no such point can beat the floor 1 by more than the tolerance, 1e-6)."""
    grid, open_loop, _, _ = _scan(model)
    s = np.abs(1.0 / (1.0 + open_loop))
    best = max(1.0, float(np.max(s)))
    padded = np.concatenate([[-np.inf], s, [-np.inf]])
    peaks = (padded[1:-1] >= padded[:-2]) & (padded[1:-1] >= padded[2:]) & (s > 1 + 1e-9)
    for i in np.flatnonzero(peaks):
        lo, hi = math.log(grid[max(i - 1, 0)]), math.log(grid[min(i + 1, grid.size - 1)])
        res = minimize_scalar(
            lambda u: -abs(1.0 / (1.0 + model.frequency_response_at(math.exp(u))[0])),
            bounds=(lo, hi), method="bounded", options={"xatol": 1e-12})
        best = max(best, -float(res.fun))
    return best


def _first_crossing(fn, grid: np.ndarray, values: np.ndarray) -> float | None:
    """Lowest ω of ``grid`` where ``fn`` (> 0 below; ``values`` on the grid; called at one
    ω [rad/s]) falls to 0, by brentq in ln ω; None when it does not."""
    below = np.flatnonzero(values <= 0)
    if below.size == 0:
        return None
    i = int(below[0])
    if i == 0 or values[i] == 0:
        return float(grid[i])
    return float(math.exp(brentq(lambda u: fn(math.exp(u)),
                                 math.log(grid[i - 1]), math.log(grid[i]), xtol=1e-14)))


def bandwidth(model) -> float:
    """Lowest ω [rad/s] with |H/H(1)|² = ½; π/T when there is none below Nyquist."""
    grid, _, closed, dc = _scan(model)
    values = np.abs(closed / dc) ** 2 - 0.5
    found = _first_crossing(lambda w: _gain_squared(model, w, dc) - 0.5, grid, values)
    return grid[-1] if found is None else found


@functools.lru_cache(maxsize=8)
def crossover(model) -> float:
    """Lowest ω [rad/s] with |L| = 1, below π/T."""
    grid, open_loop, _, _ = _scan(model)
    found = _first_crossing(lambda w: math.log(abs(model.frequency_response_at(w)[0])), grid,
                            np.log(np.abs(open_loop)))
    if found is None:
        raise NotCovered("|L| stays above 1 up to the Nyquist frequency")
    return found


def phase_margin(model) -> float:
    """180° + arg L at the crossover [deg], arg in (−360°, 0°]."""
    lo = model.frequency_response_at(crossover(model))[0]
    return math.degrees(math.atan2(-lo.imag, -lo.real))


def gain_margin(model, integrators: int = 0) -> float:
    """1/|L| [1] where the unwrapped phase of L first reaches −180° below π/T, else at π/T
    when L(−1) < 0, else +∞ (no phase crossover: python-control's gm = inf).

    ``integrators`` n > 0: the phase is unwrapped from that of L·(z − 1)^n, which starts
    near 0°, minus n·arg(z − 1) = n(90° + ωT/2): a type-2 loop's phase starts on the ±180°
    branch cut, where np.angle's side is rounding."""
    grid, lo, _, _ = _scan(model)
    if integrators:
        z = np.exp(1j * grid * model.period)
        phase = (np.unwrap(np.angle(lo * (z - 1) ** integrators))
                 - integrators * (math.pi / 2 + grid * model.period / 2) + math.pi)
    else:
        phase = np.unwrap(np.angle(lo)) + math.pi
    inner = np.flatnonzero(np.sign(phase[:-2]) != np.sign(phase[1:-1]))  # π/T itself apart
    if inner.size:
        i = int(inner[0])

        def imag(u):
            value = model.frequency_response_at(math.exp(u))[0]
            return value.imag / abs(value)

        omega = math.exp(brentq(imag, math.log(grid[i]), math.log(grid[i + 1]), xtol=1e-14))
        return float(1.0 / abs(model.frequency_response_at(omega)[0]))
    if lo[-1].real < 0:
        return float(1.0 / abs(lo[-1]))
    return math.inf


class StepPosition:
    """The position x(t) after a unit step, exact at any t [s]: the state at each sample
    from the closed loop (F, G), and between samples the drive's free motion under the
    held command in closed form, x + u·σ + (ẋ − u)·τ(1 − e^{−σ/τ}), x + u·σ without τ
    (Koren eq 3's drive): on the dense grid as rows applied to [drive state, held command]
    (:func:`_free_rows`), at any other t (the refinements' calls) in floats."""

    def __init__(self, model):
        _, _, c = model.drive_matrices()
        f, g = model.closed_loop()
        m, n = c.shape[1], f.shape[0]
        self.period = model.period
        radius = float(np.max(np.abs(model.poles())))  # eigenvalues of F, kept by the model
        if radius >= 1:
            raise NotCovered("unstable loop: no step response settles")
        self.samples = math.ceil(math.log(1e-13) / math.log(radius)) + 10 if radius > 0 else 10
        # state(i + 1) = F state(i) + G from 0: the orbit of [state, 1] under [[F, G], [0, 1]]
        # by doubling (log2(samples) products instead of a Python loop over the samples)
        from feedtune.validate.software_servo import _orbit

        affine = np.zeros((n + 1, n + 1))
        affine[:n, :n], affine[:n, n], affine[n, n] = f, g[:, 0], 1.0
        start = np.zeros(n + 1)
        start[n] = 1.0
        states = _orbit(affine, start, self.samples)[:, :n]
        held = (model.gain * (1.0 - states[:, :m] @ c[0]) if model.delay == 0
                else states[:, n - 1])
        self.starts = np.column_stack([states[:, :m], held])
        self.tau = model.time_constant
        self.dense = self.starts @ _free_rows(self.tau, self.times[0]).T  # (samples, SUBSTEPS)
        self.rows = self.starts.tolist()  # floats for __call__

    @functools.cached_property
    def times(self) -> np.ndarray:
        """The dense grid's times [s] (samples, SUBSTEPS), once: overshoot and settling
        time both read it."""
        return (np.arange(self.samples)[:, None] * self.period
                + np.arange(SUBSTEPS)[None, :] * self.period / SUBSTEPS)

    def __call__(self, t: float) -> float:
        i = min(int(t // self.period), self.samples - 1)
        sigma = t - i * self.period
        if self.tau is None:
            x, u = self.rows[i]
            return x + u * sigma
        x, v, u = self.rows[i]
        return x + u * sigma - (v - u) * self.tau * math.expm1(-sigma / self.tau)


def _free_rows(tau: float | None, sigma: np.ndarray) -> np.ndarray:
    """The drive's free motion as rows: x(σ) = [x, ẋ, u]·row(σ) for the times ``sigma`` [s]
    into a sample, row(σ) = [1, −τ·expm1(−σ/τ), σ + τ·expm1(−σ/τ)] (x + u·σ + (ẋ − u)·τ(1 −
    e^{−σ/τ}), :meth:`StepPosition.__call__`'s motion); [1, σ] without τ (state [x, u]).
    One row per time, (len(sigma), 3) or (len(sigma), 2)."""
    if tau is None:
        return np.column_stack([np.ones_like(sigma), sigma])
    decay = np.expm1(-sigma / tau)
    return np.column_stack([np.ones_like(sigma), -tau * decay, sigma + tau * decay])


@functools.lru_cache(maxsize=8)
def _step_position(model) -> StepPosition:
    return StepPosition(model)


def overshoot(model) -> float:
    """max over t of x(t) − 1 [1] after a unit step, 0 if none."""
    x = _step_position(model)
    t = x.times.ravel()
    values = x.dense.ravel()
    k = int(np.argmax(values))
    lo, hi = t[max(k - 1, 0)], t[min(k + 1, t.size - 1)]
    res = minimize_scalar(lambda s: -x(s), bounds=(lo, hi), method="bounded",
                          options={"xatol": 1e-15})
    return max(0.0, float(values[k]) - 1.0, -float(res.fun) - 1.0)


def settling_time(model, band: float) -> float:
    """Last t [s] with |1 − x(t)| = ``band`` after a unit step (0 if never outside)."""
    x = _step_position(model)
    t = x.times.ravel()
    error = 1.0 - x.dense.ravel()
    outside = np.flatnonzero(np.abs(error) > band)
    if outside.size == 0:
        return 0.0
    i = int(outside[-1])
    if i == t.size - 1:
        raise NotCovered("the step response has not settled into the band")
    side = math.copysign(band, error[i])
    return float(brentq(lambda s: 1.0 - x(s) - side, t[i], t[i + 1], xtol=1e-15))


def _step_input(model, options: dict) -> bool:
    """A sampled loop's settling time is measured after a step."""
    return options.get("input", "step") == "step"


#: metric → measurement on a sampled ServoModel (its table adds these when sampled)
MEASUREMENTS: dict[str, Measurement] = {
    "m_peak": Measurement(lambda m, o, r, c: m_peak(m)),
    "sensitivity_peak": Measurement(lambda m, o, r, c: sensitivity_peak(m)),
    "bandwidth": Measurement(lambda m, o, r, c: bandwidth(m)),
    "crossover_frequency": Measurement(lambda m, o, r, c: crossover(m)),
    "phase_margin": Measurement(lambda m, o, r, c: phase_margin(m)),
    "gain_margin": Measurement(lambda m, o, r, c: gain_margin(m)),
    "overshoot": Measurement(lambda m, o, r, c: overshoot(m)),
    "settling_time": Measurement(lambda m, o, r, c: settling_time(m, o.get("band", 0.02)),
                                 _step_input),
}
