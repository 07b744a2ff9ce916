"""The exact circle test of a sampled loop behind a linear interpolator (Sato et al. §3).

Two identical axes follow a circle of radius r at ω = V/r: the interpolator puts a vertex
P_i = r·e^{jωiT} on it every reference interval T, the servo's reference steps along each
chord every sampling period Δt_p. As one complex signal (x + jy) the reference at sample k
is the polygon at t = kΔt_p, and both axes are the same SISO loop driven by it.

**The periodic steady state in closed form.** With q = T/Δt_p = a/b (a samples span b
chords), the reference is rotation-symmetric: r_{k+a} = ρ·r_k, ρ = e^{jωbT}. The steady
state shares the symmetry, x_{k+a} = ρ·x_k, and a period of the loop x_{k+1} = Φx_k + Γr_k
gives x_a = Φ^a x_0 + Σ_{i<a} Φ^{a−1−i}Γr_i = ρ·x_0, one linear solve for x_0. For a
whole-number q (b = 1) the radial deviation repeats every side.

**A q that is not a whole number** (the servo samples fall at other places on each chord):
q is taken as the nearest fraction a/b with b ≤ MAX_CHORDS (``Fraction.limit_denominator``),
and the circle test is run for that fraction, i.e. with T' = a·Δt_p/b. q is exact for every
fraction with b ≤ 16 (Sato's Table 2: q = 130.9 = 1309/10); otherwise |T' − T| <
Δt_p/MAX_CHORDS, a relative change below 1/(16q) (0.5 % at q = 12).

**Between samples** the held command u_k = k_x·x_k + k_r·r_k drives the continuous plant:
position x + uσ for the ideal drive 1/s, x + uσ + (v − u)τ(1 − e^{−σ/τ}) for 1/(s(1+sτ)),
evaluated on SUBDIVISIONS points per sample. For the ideal drive the path is straight
between samples, so the result is exact: the smallest radius of each piece by the foot of
the perpendicular, its mean radius by Simpson's rule (error O(L⁴/r³) for a piece of length
L, below 1e-15 m). For a drive with a lag the
path curves (by the circle's own curvature, a chord between grid points would cut inside
it by ≈ (VΔt_p/SUBDIVISIONS)²/(8r)), so the statistics are taken on the grid points
themselves, which lie on the path: the mean by the trapezoidal rule of a periodic signal,
peak and valley to O((π/(SUBDIVISIONS·q))²/2) of the ripple (0.2 % at q = 1, less above).

The radial deviation is d(t) = |y(t)| − r with the centre at the circle's (the steady state
is rotation-symmetric about it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction

from feedtune.expr import is_symbolic, to_array
from feedtune.lazy import ca, np
from feedtune.loops.protocols import Capability, Loop
from feedtune.objectives.base import Metric
from feedtune.objectives.contour.circle import CircleOptions

#: sub-sample points per servo sample for the continuous response between samples
SUBDIVISIONS = 16
#: the most sides a non-integer q = a/b may take to repeat (b ≤ MAX_CHORDS)
MAX_CHORDS = 16


@dataclass(frozen=True)
class CircleTest:
    """Radial deviation of the steady circle over one period of b sides.

    Attributes
    ----------
    radius : float
        Commanded radius r [m].
    deviation : ndarray
        d = |y| − r [m] on the grid (SUBDIVISIONS points per sample, a samples).
    valleys : ndarray
        Smallest d [m] on the straight path from each grid point to the next.
    means : ndarray
        Mean of d [m] along that straight path (Simpson's rule).
    points_per_side : int
        Grid points per reference interval T (rounded to whole points for b > 1).
    ratio : Fraction
        q = a/b as used.
    """

    radius: float
    deviation: np.ndarray
    valleys: np.ndarray
    means: np.ndarray
    points_per_side: int
    ratio: Fraction

    @property
    def mean_deviation(self) -> float:
        """Time mean of d [m] over the period: the mean along each straight piece (uniform
        in time: the grid is), averaged over the pieces."""
        return float(np.mean(self.means))

    @property
    def circularity(self) -> float:
        """max d − min d [m] over the whole circle."""
        return float(np.max(self.deviation) - np.min(self.valleys))

    @property
    def roughness(self) -> float:
        """Peak-to-valley [m] of d within one side's time T (to a grid step), the worst
        over all windows of that length.

        Equal to :attr:`circularity` for a whole-number q: the deviation then repeats
        every side.
        """
        if self.ratio.denominator == 1:
            return self.circularity
        size = self.points_per_side + 1
        from scipy.ndimage import maximum_filter1d, minimum_filter1d  # 0.18 s: lazily

        peaks = maximum_filter1d(self.deviation, size, mode="wrap")
        valleys = minimum_filter1d(self.valleys, size, mode="wrap")
        return float(np.max(peaks - valleys))


def supports(loop: Loop) -> bool:
    """A sampled loop behind an interpolator, for which the test is defined."""
    return loop.interpolator is not None and loop.offers(Capability.HELD_COMMAND)


def circle_test(loop: Loop, radius: float, feed: float) -> CircleTest | None:
    """The steady circle test of ``loop`` (a loop of numbers); None when it is unstable.

    Raises
    ------
    TypeError
        For a loop of symbols: the test is numeric, evaluated on a tuned design only.
    """
    if is_symbolic(loop.state_matrix, loop.period, loop.interpolator.reference_interval):
        raise TypeError("the exact circle test is evaluated on a loop of numbers only "
                        "(reported only, never optimised)")
    phi = to_array(loop.state_matrix)
    if np.max(np.abs(np.linalg.eigvals(phi))) >= 1:
        return None
    n = phi.shape[0]
    gamma = to_array(loop.input_matrix).reshape(n)
    kx, kr = (to_array(v) for v in loop.hold_input)
    kx, kr = kx.reshape(n), float(kr.ravel()[0])
    period = float(to_array(loop.period).ravel()[0])
    interval = float(to_array(loop.interpolator.reference_interval).ravel()[0])
    omega = feed / radius
    ratio = Fraction(interval / period).limit_denominator(MAX_CHORDS)
    if ratio <= 0:
        ratio = Fraction(1, MAX_CHORDS)
    a, b = ratio.numerator, ratio.denominator
    interval = a * period / b  # T' (= T for a fraction with b ≤ MAX_CHORDS)
    # reference at samples k = 0..a−1: side i = ⌊kb/a⌋, fraction (kb mod a)/a along it
    k = np.arange(a)
    side, along = np.divmod(k * b, a)
    start = radius * np.exp(1j * omega * interval * side)
    reference = start + (along / a) * (start * np.exp(1j * omega * interval) - start)
    rotation = np.exp(1j * omega * interval * b)
    # x_a from x_0 = 0, then (ρI − Φ^a) x_0 = x_a(0)
    state = np.zeros(n, dtype=complex)
    for r_k in reference:
        state = phi @ state + gamma * r_k
    state = np.linalg.solve(rotation * np.eye(n) - np.linalg.matrix_power(phi, a), state)
    states = np.empty((a, n), dtype=complex)
    for i, r_k in enumerate(reference):
        states[i] = state
        state = phi @ state + gamma * r_k
    held = states @ kx + kr * reference  # u_k [m/s]
    sigma = np.arange(SUBDIVISIONS) / SUBDIVISIONS * period
    tau = loop.plant.time_constant
    position = states[:, :1] + held[:, None] * sigma[None, :]
    if tau is not None:
        position = position + ((states[:, 1] - held)[:, None]
                               * (tau * -np.expm1(-sigma / tau))[None, :])
    path = position.ravel()
    deviation = np.abs(path) - radius
    if tau is not None:  # curved between grid points: the points themselves
        return CircleTest(radius=radius, deviation=deviation, valleys=deviation,
                          means=deviation, points_per_side=round(SUBDIVISIONS * a / b),
                          ratio=ratio)
    following = np.append(path[1:], rotation * path[0])  # the point after the period's last
    step = following - path
    length = np.abs(step) ** 2
    foot = np.clip(-np.real(np.conj(path) * step) / np.where(length > 0, length, 1), 0, 1)
    valleys = np.abs(path + foot * step) - radius
    # mean of |p + s·d| over s ∈ [0, 1] by Simpson's rule: the radius along a piece of
    # length L ≪ r is √(h² + u²), whose 4th derivative is O(1/r³): error O(L⁴/r³) < 1e-15 m
    means = (np.abs(path) + 4 * np.abs(path + step / 2) + np.abs(following)) / 6
    return CircleTest(radius=radius, deviation=deviation, valleys=valleys,
                      means=means - radius,
                      points_per_side=round(SUBDIVISIONS * a / b), ratio=ratio)


def circle_value(loop: Loop, options, quantity: str):
    """``quantity`` of the circle test for the metric ``options`` (radius, feed), as a ca.DM;
    +∞ for an unstable loop."""
    test = circle_test(loop, options.radius, options.feed)
    return ca.DM(math.inf if test is None else getattr(test, quantity))


class CircleTestMetric(Metric):
    """A metric read from the circle test: ``quantity`` of :class:`CircleTest` [m].

    Sampled loops behind a linear interpolator (``model: exact``) only; reported only,
    never optimised (numeric, and not smooth in q = T/Δt_p). +∞ for an unstable loop.
    """

    unit = "m"
    Options = CircleOptions
    quantity: str

    def supports(self, loop: Loop, options=None):
        return supports(loop)

    def optimisable(self, loop: Loop, options=None):
        return False

    def evaluate(self, loop: Loop, options):
        return circle_value(loop, options, self.quantity)
