"""Exact time integrals of step-response errors: IAE, ISE and ITAE.

Two error shapes occur in feed-drive loops, and both are integrated in closed form, so
that the integrals are smooth functions of the loop parameters (IPOPT converges on them;
a quadrature of |e| would not, see docs/design.md numerical notes):

* a second-order continuous loop: e(t) = Re(c·e^{pt}), or a sum of two real exponentials;
* one sample of a sampled loop whose plant is an integrator with a first-order lag:
  e(τs) = α + βs + γe^{−s} on 0 ≤ s ≤ T/τ, which has at most two zeros there because
  its second derivative γe^{−s} keeps one sign.
"""

from __future__ import annotations

import functools
from typing import NamedTuple

from feedtune.lazy import ca

_TINY = 1e-300
_NEWTON_STEPS = 8


class ErrorIntegrals(NamedTuple):
    """∫|e| dt [m·s], ∫e² dt [m²·s], ∫t|e| dt [m·s²] for a unit (1 m) step."""

    iae: object
    ise: object
    itae: object


# -- continuous, second order -------------------------------------------------------

def _cmul(a, b):
    return (a[0] * b[0] - a[1] * b[1], a[0] * b[1] + a[1] * b[0])


def _cdiv(a, b):
    d = b[0] ** 2 + b[1] ** 2
    return ((a[0] * b[0] + a[1] * b[1]) / d, (a[1] * b[0] - a[0] * b[1]) / d)


def _cexp(a):
    m = ca.exp(a[0])
    return (m * ca.cos(a[1]), m * ca.sin(a[1]))


def second_order_error_integrals(a1, a0, e0, de0) -> ErrorIntegrals:
    """Exact IAE, ISE, ITAE of ë + a1·ė + a0·e = 0 with e(0) = e0 > 0, ė(0) = de0.

    Underdamped (a1² < 4a0): e(t) = Re(c e^{pt}), p = −σ + jω_d. Its zeros are spaced
    π/ω_d apart and each lobe is −q times the one before, q = e^{−σπ/ω_d}; the lobe sums
    are geometric series summed in closed form. Overdamped: e keeps the sign of e0 when
    de0 ≥ 0 − a1·e0/2 (true for the step error of a loop of relative degree two, where
    de0 = 0), so ∫|e| = ∫e. ISE from the Lyapunov equation of the companion form.

    Parameters are CasADi expressions or numbers; a1 [1/s], a0 [1/s²], e0 [m], de0 [m/s].

    Built once per process on SX symbols (:func:`_second_order_function`) and applied to
    the arguments (MX arguments get a call node, numbers DM values): building it took
    10–20 ms, every loop that needed it.
    """
    return ErrorIntegrals(*_second_order_function()(a1, a0, e0, de0))


@functools.cache
def _second_order_function() -> ca.Function:
    """:func:`_second_order` as an SX Function of (a1, a0, e0, de0)."""
    args = [ca.SX.sym(name) for name in ("a1", "a0", "e0", "de0")]
    return ca.Function("second_order_error_integrals", args, list(_second_order(*args)))


def _second_order(a1, a0, e0, de0) -> ErrorIntegrals:
    """The expressions of :func:`second_order_error_integrals`, built on what it is given."""
    sigma = a1 / 2
    omega_d = ca.sqrt(ca.fmax(a0 - sigma**2, _TINY))
    n0 = de0 + a1 * e0  # numerator of E(s) = (e0 s + n0)/(s² + a1 s + a0)
    integral_e = n0 / a0
    integral_te = (n0 * a1 - e0 * a0) / a0**2

    p = (-sigma, omega_d)
    c = (e0, -(de0 + sigma * e0) / omega_d)  # e(0) = Re c, ė(0) = Re(c p)
    phase = ca.atan2(c[1], c[0])
    period = ca.pi / omega_d
    t0 = (ca.pi / 2 - phase) / omega_d  # first zero for Re c > 0
    t1 = t0 + period

    def antiderivative(t):  # ∫e dt and ∫t e dt, up to constants
        ept = _cexp((p[0] * t, p[1] * t))
        cept = _cmul(c, ept)
        inv_p = _cdiv((1.0, 0.0), p)
        inv_p2 = _cmul(inv_p, inv_p)
        f0 = _cmul(cept, inv_p)  # ∫e^{pt} = e^{pt}/p
        f1 = _cmul(cept, (t * inv_p[0] - inv_p2[0], t * inv_p[1] - inv_p2[1]))  # ∫t e^{pt}
        return f0[0], f1[0]

    e_start, te_start = antiderivative(0)
    e_t0, te_t0 = antiderivative(t0)
    e_t1, te_t1 = antiderivative(t1)
    q = ca.exp(-sigma * period)
    first_area = ca.fabs(e_t0 - e_start)
    lobe_area = ca.fabs(e_t1 - e_t0)
    first_moment = ca.fabs(te_t0 - te_start)
    lobe_moment = ca.fabs(te_t1 - te_t0)
    iae_under = first_area + lobe_area / (1 - q)
    itae_under = first_moment + lobe_moment / (1 - q) + period * lobe_area * q / (1 - q) ** 2

    underdamped = a1**2 < 4 * a0 * (1 - 1e-9)
    iae = ca.if_else(underdamped, iae_under, integral_e)
    itae = ca.if_else(underdamped, itae_under, integral_te)
    # Lyapunov for x = [e, ė], A = [[0, 1], [−a0, −a1]], Q = diag(1, 0)
    p11 = (a1**2 + a0) / (2 * a1 * a0)
    p12 = 1 / (2 * a0)
    p22 = 1 / (2 * a1 * a0)
    ise = p11 * e0**2 + 2 * p12 * e0 * de0 + p22 * de0**2
    return ErrorIntegrals(iae, ise, itae)


# -- one sample of an integrator-with-lag plant under a held input ----------------------

def _primitive(alpha, beta, gamma, s):
    """∫ f ds and ∫ s f ds for f(s) = α + βs + γe^{−s}."""
    e = ca.exp(-s)
    return (alpha * s + beta * s**2 / 2 - gamma * e,
            alpha * s**2 / 2 + beta * s**3 / 3 - gamma * (s + 1) * e)


def _newton_root(alpha, beta, gamma, start, low, high):
    """Root of f in [low, high] by Newton's method from ``start``, kept inside the bracket."""
    s = start
    for _ in range(_NEWTON_STEPS):
        f = alpha + beta * s + gamma * ca.exp(-s)
        df = beta - gamma * ca.exp(-s)
        df = ca.if_else(ca.fabs(df) < 1e-200, 1e-200, df)
        s = ca.fmin(ca.fmax(s - f / df, low), high)
    return s


def _newton_start(alpha, beta, gamma, end, low, high, middle, interior):
    """A start from which Newton converges fast to the one root in [low, high].

    f is monotone and convex or concave on [low, high], so Newton's first step from any
    point of the bracket lands (clamped) on the side where f·f'' > 0, and from there it
    converges monotonically; the start only decides how many steps that takes. Of these
    guesses the one where |f| is smallest is used:

    * next to an interior stationary point (a near-double root): the root of the quadratic
      Taylor model there;
    * else, where γe^{−s} dominates: s = ln(γ/−(α + β·end)) (a far root is then reached in
      a few steps instead of one unit of s per step);
    * else the end of the bracket where f·f'' > 0 (``end``).
    """
    f_m = alpha + beta * middle + gamma * ca.exp(-middle)
    curvature = gamma * ca.exp(-middle)
    # every guard below keeps derivatives finite: a NaN in a branch not taken still spreads
    offset = ca.sqrt(ca.fmax(-2 * f_m / ca.if_else(curvature == 0, 1, curvature), _TINY))
    quadratic = ca.if_else(end > middle, middle + offset, middle - offset)
    level = -(alpha + beta * end)
    ratio = gamma / ca.if_else(level == 0, 1, level) * (level != 0)
    logarithmic = ca.if_else(ratio > 0, ca.log(ca.fmax(ratio, _TINY)), end)
    use_quadratic = interior * (f_m * gamma < 0) * (curvature != 0)
    quadratic = ca.if_else(use_quadratic, quadratic, end)
    best = end
    for candidate in (quadratic, logarithmic):  # keep the guess where |f| is smallest
        candidate = ca.fmin(ca.fmax(candidate, low), high)
        smaller = (ca.fabs(alpha + beta * candidate + gamma * ca.exp(-candidate))
                   < ca.fabs(alpha + beta * best + gamma * ca.exp(-best)))
        best = ca.if_else(smaller, candidate, best)
    return best


def sample_error_integrals(alpha, beta, gamma, h, time_scale, t_start) -> ErrorIntegrals:
    """Exact integrals over one sample of e(t_start + τs) = α + βs + γe^{−s}, 0 ≤ s ≤ h.

    ``time_scale`` is τ [s], ``h`` = T/τ. The sample is cut at the stationary point of f
    and at the (at most two) zeros, so each piece has one sign and |∫| = ∫|·|.

    Built on whatever it is given; the sampled loop builds it once per process, on SX
    symbols, inside :func:`feedtune.loops.loop._sample_step`.
    """
    f = lambda s: alpha + beta * s + gamma * ca.exp(-s)  # noqa: E731
    ratio_ok = gamma * beta > 0
    stationary = ca.if_else(ratio_ok, ca.log(ca.fmax(gamma / ca.if_else(ratio_ok, beta, 1), _TINY)), h)
    middle = ca.fmin(ca.fmax(stationary, 0), h)
    f0, fm, fh = f(0), f(middle), f(h)
    # Newton starts: near the stationary point if it is interior, else the end where f has
    # the sign of γ (f'' = γe^{−s}), improved by a logarithmic guess
    interior = (middle > 0) * (middle < h)
    end1 = ca.if_else(f0 * gamma > 0, 0, middle)
    end2 = ca.if_else(fh * gamma > 0, h, middle)
    start1 = _newton_start(alpha, beta, gamma, end1, 0, middle, middle, interior)
    start2 = _newton_start(alpha, beta, gamma, end2, middle, h, middle, interior)
    zero1 = ca.if_else(f0 * fm < 0, _newton_root(alpha, beta, gamma, start1, 0, middle), middle)
    zero2 = ca.if_else(fm * fh < 0, _newton_root(alpha, beta, gamma, start2, middle, h), h)
    cuts = [0, zero1, middle, zero2, h]
    prims = [_primitive(alpha, beta, gamma, s) for s in cuts]
    iae = 0
    itae = 0
    for (f_a, g_a), (f_b, g_b) in zip(prims[:-1], prims[1:]):
        iae += ca.fabs(f_b - f_a)
        itae += ca.fabs(t_start * (f_b - f_a) + time_scale * (g_b - g_a))
    eh = ca.exp(-h)
    ise = (alpha**2 * h + alpha * beta * h**2 + beta**2 * h**3 / 3
           + 2 * alpha * gamma * (1 - eh) + 2 * beta * gamma * (1 - eh * (1 + h))
           + gamma**2 * (1 - eh**2) / 2)
    return ErrorIntegrals(time_scale * iae, time_scale * ise, time_scale * itae)


def sample_moments(a, b, g, h, time_scale):
    """Per-sample ∫e dt, ∫σ·e dσ and ∫e² dt when α, β, γ are linear forms a·δ, b·δ, g·δ.

    Returns row vectors c1, c2 and the symmetric matrix Q with ∫e dt = c1·δ [m·s],
    ∫σe dσ = c2·δ [m·s²] and ∫e² dt = δᵀQδ [m²·s] over one sample of length τh.
    """
    eh = ca.exp(-h)
    tau = time_scale
    c1 = tau * (a * h + b * h**2 / 2 + g * (1 - eh))
    c2 = tau**2 * (a * h**2 / 2 + b * h**3 / 3 + g * (1 - (1 + h) * eh))

    def sym(x, y):
        return ca.mtimes(x.T, y) + ca.mtimes(y.T, x)

    q = tau * (h * ca.mtimes(a.T, a) + h**2 / 2 * sym(a, b) + h**3 / 3 * ca.mtimes(b.T, b)
               + (1 - eh) * sym(a, g) + (1 - eh * (1 + h)) * sym(b, g)
               + (1 - eh**2) / 2 * ca.mtimes(g.T, g))
    return c1, c2, q
