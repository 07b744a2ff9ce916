"""Fitting a :class:`~feedtune.measured.rational.Rational` model to measured data.

Two stages (docs/design.md, "Identification"):

1. **Linear in the parameters, in cvxpy.** Multiplying through by the denominator makes
   the model's error linear in (a, b). Frequency data: Levy's fit, then
   Sanathanan–Koerner iterations that divide each equation by the previous a(jω), so the
   weighted equation error becomes the relative output error as they converge. Time data:
   the equation error of the derivatives of command and output seen through a
   state-variable filter 1/(s/λ + 1)^N (Young's SVF), which needs no noisy derivatives.
   Constraints: a_i ≥ 0 (necessary for a stable a(s), sufficient up to second order) and,
   for the physical drives, a positive gain b_0 ≥ 0. Above second order an unstable
   result has its unstable poles reflected into the left half-plane (|a(jω)| unchanged)
   and its numerator refitted by linear least squares. The least-squares problem is
   compressed by a QR factorisation to its p×p triangle first, so its size in cvxpy does
   not grow with the number of points; cvxpy solves it when a constraint is active (the
   unconstrained minimiser is the answer otherwise). A dead time is found on a grid (phase steps of
   0.3 rad at the highest frequency; whole samples for time data), each point one fit.
2. **Output error, scipy.optimize.least_squares.** The equation error is biased by noise on
   the output (it multiplies the noise by a(s)); the output error (the model's response
   against the data, relative at each frequency) is the maximum-likelihood fit for
   independent Gaussian output noise, and its Jacobian at the optimum gives the
   parameters' standard errors, cov = s²(JᵀJ)⁻¹ with s² the residual variance. Should
   its optimum be unstable (above second order), it is fitted again over denominators
   written as products of second-order factors with positive coefficients, all stable.

References
----------
E. C. Levy, "Complex-curve fitting", IRE Trans. Automatic Control AC-4, 1959, pp. 37–43.
C. K. Sanathanan, J. Koerner, "Transfer function synthesis as a ratio of two complex
polynomials", IEEE Trans. Automatic Control 8(1), 1963, pp. 56–58.
P. C. Young, "Parameter estimation for continuous-time models — a survey", Automatica
17(1), 1981, pp. 23–39 (state-variable filters).
L. Ljung, *System Identification: Theory for the User*, 2nd ed., 1999, §9.3 (the
covariance of a prediction-error estimate).
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass

import numpy as np
from scipy import linalg, optimize, signal

from feedtune.measured.data import FrequencyResponseData, MeasuredData, TimeSeriesData
from feedtune.measured.rational import Rational

#: Sanathanan–Koerner: at most this many iterations, stopping when no scaled parameter moves
#: by more than SK_TOLERANCE
SK_ITERATIONS = 30
SK_TOLERANCE = 1e-9
#: iterations at each point of a dead-time grid (enough to rank the points)
GRID_SK_ITERATIONS = 3
#: the dead-time grid of frequency data: this phase step at the highest frequency [rad]
DEAD_TIME_PHASE_STEP = 0.3
#: default largest dead time: this phase at the highest measured frequency [rad] (two turns),
#: or this many samples of a time series
DEAD_TIME_PHASE = 4 * np.pi
DEAD_TIME_SAMPLES = 20
#: state-variable filter bandwidths tried, as multiples of the band's geometric centre
SVF_BANDWIDTHS = (0.3, 1.0, 3.0)


class FitError(ValueError):
    """The data cannot determine the model (too few points, a failed solve)."""


@dataclass(frozen=True)
class Structure:
    """The shape of G(s) = b(s)/(s^k a(s)) e^{−θs}: deg b = zeros, deg a = poles, k =
    integrators; whether θ is fitted; whether b_0 ≥ 0 is imposed."""

    zeros: int
    poles: int
    integrators: int
    dead_time: bool
    positive_gain: bool

    @property
    def linear_size(self) -> int:
        """Parameters entering linearly: a_1 … a_n, b_0 … b_m."""
        return self.poles + self.zeros + 1

    def names(self) -> list[str]:
        return ([f"a{i}" for i in range(1, self.poles + 1)]
                + [f"b{j}" for j in range(self.zeros + 1)]
                + (["dead_time"] if self.dead_time else []))

    def rational(self, x: np.ndarray, omega0: float) -> Rational:
        """The model of scaled parameters x (s' = s/ω0: a_i ω0^i, b_j ω0^j, θ ω0)."""
        n, m = self.poles, self.zeros
        a = np.concatenate([[1.0], x[:n] / omega0 ** np.arange(1, n + 1)])
        b = x[n:n + m + 1] / omega0 ** np.arange(m + 1)
        theta = x[n + m + 1] / omega0 if self.dead_time else 0.0
        return Rational(b, a, self.integrators, theta)

    def scale(self, omega0: float) -> np.ndarray:
        """Physical parameter = scaled parameter × this."""
        n, m = self.poles, self.zeros
        return np.concatenate([omega0 ** -np.arange(1, n + 1.0), omega0 ** -np.arange(m + 1.0),
                               [1 / omega0] if self.dead_time else []])


@dataclass(frozen=True)
class Fit:
    """The output-error fit: parameters (physical, in :meth:`Structure.names` order), their
    covariance, the model, each data set's model response and NRMSE, offsets of time data."""

    structure: Structure
    parameters: np.ndarray
    covariance: np.ndarray
    model: Rational
    nrmse: list[float]
    offsets: list[float | None]
    residual_variance: float
    degrees_of_freedom: int
    linear_iterations: int
    output_error_evaluations: int
    stabilisation: str = ""


def band(data: list[MeasuredData]) -> tuple[float, float]:
    """(lowest, highest) frequency the data describe [rad/s]: a frequency response its
    range; a time series 2π/duration to π/T."""
    lows, highs = [], []
    for d in data:
        if isinstance(d, FrequencyResponseData):
            lows.append(d.frequency_rad_s[0])
            highs.append(d.frequency_rad_s[-1])
        else:
            lows.append(2 * np.pi / (d.time_s[-1] - d.time_s[0]))
            highs.append(np.pi / d.sample_period)
    return min(lows), max(highs)


def _derivative(d: MeasuredData) -> int:
    return 1 if d.output_kind == "velocity" else 0


# ---------------------------------------------------------------- stage 1: cvxpy


@functools.lru_cache(maxsize=32)
def _problem(size: int, nonnegative: tuple[int, ...]):
    """min ‖R z − q‖² s.t. z_i ≥ 0 (i in ``nonnegative``), R and q parameters: built once
    per shape, solved again for every Sanathanan–Koerner iteration and dead time."""
    import cvxpy as cp

    z = cp.Variable(size)
    r = cp.Parameter((size, size))
    q = cp.Parameter(size)
    constraints = [z[list(nonnegative)] >= 0] if nonnegative else []
    return cp.Problem(cp.Minimize(cp.sum_squares(r @ z - q)), constraints), z, r, q


def _constrained_lstsq(phi: np.ndarray, target: np.ndarray, structure: Structure) -> np.ndarray:
    """argmin ‖Φx − y‖² with the sign constraints, after scaling Φ's columns to unit norm
    and reducing Φ to the triangle R of its QR factorisation (‖Φx − y‖² = ‖Rx − Qᵀy‖² +
    const). The unconstrained minimiser R⁻¹Qᵀy is the answer when it meets the sign
    constraints (the problem is convex: zero multipliers satisfy its KKT conditions);
    otherwise cvxpy (Clarabel) solves the constrained problem."""
    import cvxpy as cp

    norms = np.linalg.norm(phi, axis=0)
    if np.any(norms == 0) or not np.all(np.isfinite(phi)):
        raise FitError("the data do not excite every parameter of the model")
    q_mat, r_mat = np.linalg.qr(phi / norms)
    rhs = q_mat.T @ target
    n = structure.poles
    nonnegative = tuple(range(n)) + ((n,) if structure.positive_gain else ())
    try:
        free = linalg.solve_triangular(r_mat, rhs)
    except np.linalg.LinAlgError:
        free = None
    if free is not None and np.all(np.isfinite(free)) and np.all(free[list(nonnegative)] >= 0):
        return free / norms
    problem, z, r, q = _problem(phi.shape[1], nonnegative)
    r.value, q.value = r_mat, rhs
    problem.solve(solver=cp.CLARABEL)
    if z.value is None or problem.status not in ("optimal", "optimal_inaccurate"):
        raise FitError(f"the linear least-squares fit failed ({problem.status})")
    return z.value / norms


def _frequency_rows(d: FrequencyResponseData, structure: Structure, omega0: float,
                    theta: float, previous: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Rows (real and imaginary parts) of a(jω)Z − b(jω) = 0, Z = H (jω)^{k−d} e^{jωθ},
    weighted by coherence/(|Z| |a_prev(jω)|) and 1/√N, so each set weighs the same."""
    nu = 1j * d.frequency_rad_s / omega0
    z = (d.response * (1j * d.frequency_rad_s) ** (structure.integrators - _derivative(d))
         * np.exp(1j * d.frequency_rad_s * theta))
    weight = 1.0 / np.abs(z) / np.sqrt(len(z))
    if d.coherence is not None:
        weight = weight * d.coherence
    if previous is not None:
        weight = weight / np.abs(np.polynomial.polynomial.polyval(nu, previous))
    n, m = structure.poles, structure.zeros
    columns = [nu ** i * z for i in range(1, n + 1)] + [-(nu ** j) for j in range(m + 1)]
    phi = np.column_stack(columns) * weight[:, None]
    target = -z * weight
    return np.vstack([phi.real, phi.imag]), np.concatenate([target.real, target.imag])


@dataclass(frozen=True)
class _Filtered:
    """A time series through the state-variable filter: columns ν^i F y (i = 0…N) and
    ν^j F u (j = 0…m), ν = s/ω0."""

    outputs: np.ndarray
    inputs: np.ndarray


def _filtered(d: TimeSeriesData, structure: Structure, omega0: float, lam: float) -> _Filtered:
    order = structure.poles + structure.integrators - _derivative(d)
    if order < 1 or structure.zeros >= order:
        raise FitError("the model must have more poles than zeros")
    fs = 1.0 / d.sample_period
    y = d.output - d.output[0]

    def through(signal_in, power):
        num = np.zeros(power + 1)
        num[0] = (lam / omega0) ** power      # ν^i = (λ/ω0)^i (s/λ)^i
        den = np.poly(-np.ones(order))        # (s/λ + 1)^N; in time scaled by λ
        b, a = signal.bilinear(num, den, fs=fs / lam)
        return signal.lfilter(b, a, signal_in)

    outputs = np.column_stack([through(y, i) for i in range(order + 1)])
    inputs = np.column_stack([through(d.command, j) for j in range(structure.zeros + 1)])
    return _Filtered(outputs, inputs)


def _time_rows(f: _Filtered, d: TimeSeriesData, structure: Structure,
               delay: int) -> tuple[np.ndarray, np.ndarray]:
    """Rows of ν^{k−d} F y + Σ a_i ν^{i+k−d} F y − Σ b_j ν^j F u(t − delay·T) = 0, scaled so
    that the set's target has unit norm."""
    k = structure.integrators - _derivative(d)
    inputs = f.inputs if delay == 0 else np.vstack([np.zeros((delay, f.inputs.shape[1])),
                                                    f.inputs[:-delay]])
    phi = np.column_stack([f.outputs[:, k + 1:k + 1 + structure.poles], -inputs])
    target = -f.outputs[:, k]
    norm = np.linalg.norm(target)
    return phi / norm, target / norm


def linear_fit(data: list[MeasuredData], structure: Structure, omega0: float,
               max_dead_time: float | None) -> tuple[np.ndarray, int]:
    """Stage 1: scaled parameters (a', b', θω0) and the number of least-squares solves."""
    _, high = band(data)
    frequency = [d for d in data if isinstance(d, FrequencyResponseData)]
    series = [d for d in data if isinstance(d, TimeSeriesData)]
    period = min((d.sample_period for d in series), default=None)
    if structure.dead_time:
        if max_dead_time is None:
            max_dead_time = (DEAD_TIME_PHASE / high if frequency
                             else DEAD_TIME_SAMPLES * period)
        step = DEAD_TIME_PHASE_STEP / high if frequency else period
        thetas = np.arange(0.0, max_dead_time + step / 2, step)
    else:
        thetas = np.zeros(1)
    lo, hi = band(data)
    centre = np.sqrt(lo * hi)
    filters = {factor: [_filtered(d, structure, omega0, factor * centre) for d in series]
               for factor in (SVF_BANDWIDTHS if series else (1.0,))}
    middle = list(filters)[len(filters) // 2]
    solves = 0

    def run(factor, theta, iterations):
        nonlocal solves
        x, count, cost = _sk(frequency, series, filters[factor], structure, omega0, theta,
                             iterations)
        solves += count
        if series:  # equation errors of different filters are not comparable: simulate
            cost = output_error_cost(data, structure, omega0,
                                     np.append(x, theta * omega0) if structure.dead_time else x)
        return cost, x, theta

    # the dead time on the grid (a few Sanathanan–Koerner iterations each, the middle
    # filter), then the filters at that dead time, then the best to convergence
    best = min((run(middle, theta, GRID_SK_ITERATIONS) for theta in thetas),
               key=lambda c: c[0])
    theta = best[2]
    best = min((run(factor, theta, SK_ITERATIONS) for factor in filters), key=lambda c: c[0])
    _, x, theta = best
    if structure.dead_time:
        x = np.append(x, theta * omega0)
    return x, solves


def _sk(frequency, series, filtered, structure, omega0, theta, iterations):
    """Levy, then Sanathanan–Koerner iterations (frequency data; time data are fitted once
    by equation error): (x, solves, weighted residual)."""
    previous = None
    x = None
    rows_time = [_time_rows(f, d, structure, int(round(theta / d.sample_period)))
                 for f, d in zip(filtered, series)]
    solves = 0
    for _ in range(iterations if frequency else 1):
        rows = [_frequency_rows(d, structure, omega0, theta, previous) for d in frequency]
        rows += rows_time
        phi = np.vstack([r[0] for r in rows])
        target = np.concatenate([r[1] for r in rows])
        new = _constrained_lstsq(phi, target, structure)
        solves += 1
        converged = x is not None and np.max(np.abs(new - x)) <= SK_TOLERANCE * max(
            1.0, np.max(np.abs(x)))
        x = new
        previous = np.concatenate([[1.0], x[:structure.poles]])
        if converged:
            break
    cost = float(np.sum((phi @ x - target) ** 2))
    return x, solves, cost


# ---------------------------------------------------------------- stage 2: output error


def _residuals(x, data, structure, omega0, weights):
    """Stacked output errors: relative at each frequency (times coherence), and
    (model − data)/(set weight) for time series; x ends with one offset per time series."""
    model = structure.rational(x, omega0)
    out = []
    offsets = iter(x[len(structure.names()):])
    for d, w in zip(data, weights):
        if isinstance(d, FrequencyResponseData):
            err = (model.response(d.frequency_rad_s, _derivative(d)) - d.response) / np.abs(
                d.response)
            if d.coherence is not None:
                err = err * d.coherence
            out += [err.real / w, err.imag / w]
        else:
            y = model.simulate(d.command, d.sample_period, _derivative(d)) + next(offsets)
            out.append((y - d.output) / w)
    return np.concatenate(out)


def _initial_weights(data):
    return [1.0 if isinstance(d, FrequencyResponseData) else float(np.std(d.output)) or 1.0
            for d in data]


def output_error_cost(data, structure, omega0, x) -> float:
    """Σ r² of the output error at scaled parameters x (offsets: the first output samples)."""
    offsets = [d.output[0] for d in data if isinstance(d, TimeSeriesData)]
    r = _residuals(np.concatenate([x, offsets]), data, structure, omega0,
                   _initial_weights(data))
    return float(r @ r) if np.all(np.isfinite(r)) else np.inf


def hurwitz(a: np.ndarray) -> bool:
    """Whether 1 + a_1 s + … + a_n s^n (``a`` = a_1 … a_n) has every root in the open left
    half-plane: a stable model."""
    roots = np.polynomial.polynomial.polyroots(np.concatenate([[1.0], a]))
    return bool(np.all(roots.real < 0))


def reflected(a: np.ndarray) -> np.ndarray:
    """a_1 … a_n of 1 + a_1 s + … + a_n s^n with every root r in the closed right
    half-plane replaced by −r̄ (its mirror image in the imaginary axis): |a(jω)| is
    unchanged at every ω, so the magnitude the fit matched is kept and only the phase
    moves (an all-pass factor)."""
    roots = np.polynomial.polynomial.polyroots(np.concatenate([[1.0], a]))
    roots = np.where(roots.real >= 0, -np.abs(roots.real) + 1j * roots.imag, roots)
    poly = np.polynomial.polynomial.polyfromroots(roots).real
    return poly[1:] / poly[0]


def refit_numerator(data: list[MeasuredData], structure: Structure, omega0: float,
                    x: np.ndarray) -> np.ndarray:
    """``x`` (scaled parameters) with b_0 … b_m chosen by linear least squares on the
    output error, the denominator and dead time held: the output error is affine in b and
    in the time series' offsets, so its Jacobian in them is exact from one evaluation per
    parameter (scipy ``lsq_linear``, b_0 ≥ 0 for a positive gain)."""
    n, m = structure.poles, structure.zeros
    offsets = [d.output[0] for d in data if isinstance(d, TimeSeriesData)]
    start = np.concatenate([x, offsets])
    free = list(range(n, n + m + 1)) + list(range(len(x), len(start)))
    weights = _initial_weights(data)

    def residual(values):
        z = start.copy()
        z[free] = values
        return _residuals(z, data, structure, omega0, weights)

    base = residual(np.zeros(len(free)))
    jac = np.column_stack([residual(unit) - base for unit in np.eye(len(free))])
    lower = np.full(len(free), -np.inf)
    if structure.positive_gain:
        lower[0] = 0.0
    solution = optimize.lsq_linear(jac, -base, bounds=(lower, np.inf)).x
    out = x.copy()
    out[n:n + m + 1] = solution[:m + 1]
    return out


#: the lightest damping ratio a fitted mode may have in the factored fit [1]: lighter than
#: any machine-tool structure's (steel weldments and castings: 0.002-0.05), so it binds
#: only where the data would otherwise place a pole on or across the imaginary axis
MIN_DAMPING = 1e-3


@dataclass(frozen=True)
class Factors:
    """A denominator of order n written as a product of second-order factors (and one
    first-order factor when n is odd), in the scaled variable ν:

        a(ν) = Π_k (1 + 2ζ_k ν/ω_k + ν²/ω_k²) · (1 + ν/p),

    parameters (ζ_k, ln ω_k) per pair and ln p, with ζ_k ≥ :data:`MIN_DAMPING`. Each
    factor with ζ > 0 has its roots in the left half-plane (a quadratic's Routh array), so
    every model of this parametrisation is stable, with a decay rate of at least ζ_min·ω_k
    per mode: the output-error fit searched over it keeps the stability that a_i ≥ 0
    guarantees only up to order 2."""

    poles: int

    def _factors(self, f: np.ndarray) -> list[tuple[np.ndarray, list[np.ndarray]]]:
        """Each factor's ascending coefficients and their derivatives in its parameters."""
        out = []
        for k in range(self.poles // 2):
            zeta, inverse = f[2 * k], np.exp(-f[2 * k + 1])
            out.append((np.array([1.0, 2 * zeta * inverse, inverse ** 2]),
                        [np.array([0.0, 2 * inverse, 0.0]),
                         np.array([0.0, -2 * zeta * inverse, -2 * inverse ** 2])]))
        if self.poles % 2:
            inverse = np.exp(-f[-1])
            out.append((np.array([1.0, inverse]), [np.array([0.0, -inverse])]))
        return out

    def lower(self) -> np.ndarray:
        """The parameters' lower bounds: ζ_k ≥ MIN_DAMPING, the logarithms free."""
        bounds = [MIN_DAMPING, -np.inf] * (self.poles // 2)
        return np.array(bounds + [-np.inf] * (self.poles % 2))

    def coefficients(self, f: np.ndarray) -> np.ndarray:
        """a_1 … a_n of the product."""
        poly = np.array([1.0])
        for factor, _ in self._factors(f):
            poly = np.polynomial.polynomial.polymul(poly, factor)
        return poly[1:]

    def jacobian(self, f: np.ndarray) -> np.ndarray:
        """∂(a_1 … a_n)/∂f (n × n): each factor's derivative times the others' product."""
        factors = self._factors(f)
        columns = []
        for k, (_, derivatives) in enumerate(factors):
            others = np.array([1.0])
            for i, (other, _) in enumerate(factors):
                if i != k:
                    others = np.polynomial.polynomial.polymul(others, other)
            for d in derivatives:  # polymul drops trailing zeros: pad back to degree n
                product = np.polynomial.polynomial.polymul(d, others)
                columns.append(np.pad(product, (0, self.poles + 1 - len(product)))[1:])
        return np.column_stack(columns)

    def of(self, a: np.ndarray) -> np.ndarray:
        """The parameters of a_1 … a_n (roots in the left half-plane; a lighter damping is
        raised to MIN_DAMPING): complex roots paired with their conjugates, real roots in
        order of size (two real roots make a factor with ζ ≥ 1), the fastest real root
        alone when n is odd."""
        roots = np.polynomial.polynomial.polyroots(np.concatenate([[1.0], a]))
        pairs = [(r, np.conj(r)) for r in sorted((r for r in roots if r.imag > 0), key=abs)]
        real = sorted((r.real for r in roots if r.imag == 0), key=abs)
        single = real.pop() if self.poles % 2 else None
        pairs += [(real[i], real[i + 1]) for i in range(0, len(real), 2)]
        f = []
        for r1, r2 in pairs:  # (1 − ν/r1)(1 − ν/r2) = 1 + 2ζν/ω + ν²/ω²
            omega = float(np.sqrt(np.real(r1 * r2)))
            f += [max(float(np.real(-(r1 + r2))) / (2 * omega), MIN_DAMPING), np.log(omega)]
        if single is not None:
            f.append(np.log(abs(single)))
        return np.array(f)


def output_error_fit(data: list[MeasuredData], structure: Structure, omega0: float,
                     x0: np.ndarray, solves: int) -> Fit:
    """Stage 2: least_squares on the output error from the linear fit x0.

    The linear fit's a_i ≥ 0 makes a(s) stable only up to order 2. Above it, an unstable
    x0 has its unstable poles reflected into the left half-plane and its numerator refitted
    (:func:`reflected`, :func:`refit_numerator`); the output error is then fitted in the
    coefficients as before, and if that optimum is unstable, again over the stable
    factored denominators (:class:`Factors`), whose optimum is stable by construction.
    """
    stabilisation = ""
    if structure.poles > 2 and not hurwitz(x0[:structure.poles]):
        x0 = x0.copy()
        x0[:structure.poles] = reflected(x0[:structure.poles])
        x0 = refit_numerator(data, structure, omega0, x0)
        stabilisation = ("the linear fit's unstable poles reflected into the left "
                         "half-plane, its numerator refitted")
    result = _output_error(data, structure, omega0, x0, solves, None)
    if structure.poles > 2 and not hurwitz(result.parameters[:structure.poles]):
        result = _output_error(data, structure, omega0, x0, solves, Factors(structure.poles))
        stabilisation = "; ".join(filter(None, [
            stabilisation, "the output error fitted over stable second-order factors of "
                           "the denominator (the coefficients' optimum was unstable)"]))
    return dataclasses.replace(result, stabilisation=stabilisation)


def _output_error(data: list[MeasuredData], structure: Structure, omega0: float,
                  x0: np.ndarray, solves: int, factors: Factors | None) -> Fit:
    """:func:`output_error_fit`'s least squares, over the denominator's coefficients
    (``factors`` None) or its stable factors. With several data sets, each set is weighted
    by its own residual RMS and the fit repeated once (its noise level is not known
    beforehand). The covariance is of the coefficients either way (the factors' Jacobian
    mapped through ∂a/∂f)."""
    p, n = len(structure.names()), structure.poles
    offsets = [d.output[0] for d in data if isinstance(d, TimeSeriesData)]
    x = np.concatenate([x0, offsets])
    if factors is not None:
        x[:n] = factors.of(x[:n])

    def coefficients(z):
        if factors is None:
            return z
        return np.concatenate([factors.coefficients(z[:n]), z[n:]])

    def residuals(z, weights):
        return _residuals(coefficients(z), data, structure, omega0, weights)

    lower = np.full(len(x), -np.inf)
    lower[:n] = 0.0 if factors is None else factors.lower()
    if structure.positive_gain:
        lower[n] = 0.0
    if structure.dead_time:
        lower[p - 1] = 0.0
    x = np.maximum(x, lower)
    weights = _initial_weights(data)
    evaluations = 0
    for attempt in range(2 if len(data) > 1 else 1):
        result = optimize.least_squares(residuals, x, bounds=(lower, np.inf), x_scale="jac",
                                        args=(weights,), method="trf", xtol=1e-12,
                                        ftol=1e-12, gtol=1e-12)
        evaluations += result.nfev
        x = result.x
        if attempt == 0 and len(data) > 1:
            r = residuals(x, [1.0] * len(data))
            weights = [float(np.sqrt(np.mean(part ** 2))) or 1.0
                       for part in _split(r, data)]
    r = result.fun
    dof = len(r) - len(x)
    if dof <= 0:
        raise FitError(f"{len(r)} residuals for {len(x)} parameters: give more points")
    variance = float(r @ r) / dof
    jac = result.jac
    if factors is not None:  # J_a = J_f (∂a/∂f)⁻¹
        jac = jac.copy()
        try:
            jac[:, :n] = linalg.solve(factors.jacobian(x[:n]).T, jac[:, :n].T).T
        except np.linalg.LinAlgError:
            raise FitError("the fitted denominator has repeated factors: its coefficients' "
                           "uncertainty is undefined; fit fewer poles") from None
        x = coefficients(x)
    _, sv, vt = np.linalg.svd(jac, full_matrices=False)
    if sv[-1] <= sv[0] * 1e-12:
        raise FitError("the parameters are not identifiable from these data (singular "
                       "Jacobian): excite the axis over a wider band or fit fewer parameters")
    cov_scaled = variance * (vt.T / sv ** 2) @ vt
    scale = np.concatenate([structure.scale(omega0), np.ones(len(x) - p)])
    covariance = cov_scaled * np.outer(scale, scale)
    model = structure.rational(x, omega0)
    nrmse = [nrmse_of(model, d, off) for d, off in zip(data, _offsets_per_set(data, x[p:]))]
    return Fit(structure, x[:p] * scale[:p], covariance[:p, :p], model, nrmse,
               _offsets_per_set(data, x[p:]), variance, dof, solves, evaluations)


def _split(r: np.ndarray, data) -> list[np.ndarray]:
    parts, start = [], 0
    for d in data:
        size = 2 * len(d.frequency_rad_s) if isinstance(d, FrequencyResponseData) \
            else len(d.time_s)
        parts.append(r[start:start + size])
        start += size
    return parts


def _offsets_per_set(data, offsets) -> list[float | None]:
    it = iter(offsets)
    return [None if isinstance(d, FrequencyResponseData) else float(next(it)) for d in data]


def model_output(model: Rational, d: MeasuredData, offset: float | None) -> np.ndarray:
    """The model's counterpart of the data: G(jω) (complex) or the simulated output."""
    if isinstance(d, FrequencyResponseData):
        return model.response(d.frequency_rad_s, _derivative(d))
    return model.simulate(d.command, d.sample_period, _derivative(d)) + offset


def nrmse_of(model: Rational, d: MeasuredData, offset: float | None) -> float:
    """Normalised RMS error [1]: time series ‖y − ŷ‖/‖y − ȳ‖; frequency response the RMS
    relative error √(mean |G − Ĝ|²/|G|²)."""
    fitted = model_output(model, d, offset)
    if isinstance(d, FrequencyResponseData):
        return float(np.sqrt(np.mean(np.abs(fitted - d.response) ** 2 / np.abs(d.response) ** 2)))
    return float(np.linalg.norm(d.output - fitted) / np.linalg.norm(d.output - d.output.mean()))


def fit(data: list[MeasuredData], structure: Structure,
        max_dead_time: float | None = None) -> Fit:
    """Both stages on every data set together (one model for the axis)."""
    points = sum(2 * len(d.frequency_rad_s) if isinstance(d, FrequencyResponseData)
                 else len(d.time_s) for d in data)
    if points <= len(structure.names()) + 1:
        raise FitError(f"{points} data values for {len(structure.names())} parameters")
    lo, hi = band(data)
    omega0 = float(np.sqrt(lo * hi))
    x0, solves = linear_fit(data, structure, omega0, max_dead_time)
    return output_error_fit(data, structure, omega0, x0, solves)
