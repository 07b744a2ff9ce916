"""Discrete controllers of the general sampled-data loop: state space, discretised transfer
functions (Tustin, backward Euler) and the P position + PI velocity cascade."""

from __future__ import annotations

from dataclasses import dataclass

from feedtune.lazy import ca
from feedtune.loops import linalg
from feedtune.loops.sampled_plants import SampledModelError

#: the controller's input columns, in this order
CONTROLLER_INPUTS = ("reference", "position", "velocity")


@dataclass(frozen=True, eq=False)
class DiscreteController:
    """x_c(k+1) = A_c x_c + B_c w(k), u(k) = C_c x_c + D_c w(k), w = [r, y, v] at sample k.

    Matrices are CasADi expressions (of T and the tunables) or numbers; B_c has 3 columns
    and D_c is 1×3, in the order :data:`CONTROLLER_INPUTS` (reference, sampled position,
    sampled velocity). A static controller has a 0×0 A_c.
    """

    a: object
    b: object
    c: object
    d: object
    uses_velocity: bool = False  # whether the velocity column may be non-zero

    @property
    def order(self) -> int:
        return int(ca.MX(self.a).shape[0])


def _binomial_power(root_sign: float, power: int) -> list:
    """(z + root_sign)^power, highest power first."""
    out = [1]
    for _ in range(power):
        out = linalg.poly_mul(out, [1, root_sign])
    return out


def discretise_transfer(numerator: list, denominator: list, period, method: str = "tustin"):
    """(numerator, denominator) in z, highest power first, of a continuous C(s).

    ``tustin``: s = (2/T)(z − 1)/(z + 1), which maps the stable half plane onto the unit
    disc and the jω axis onto the unit circle (a stable C stays stable, second-order
    accurate, frequencies warped by tan(ωT/2)); the default. ``backward_euler``:
    s = (z − 1)/(T z), first order, how many drives implement their PI (the integrator
    sums e(k)·T). Coefficients are expressions of the tunables; C must be proper.
    """
    numerator, denominator = list(numerator), list(denominator)
    while len(denominator) > 1 and isinstance(denominator[0], (int, float)) and denominator[0] == 0:
        denominator.pop(0)
    n = len(denominator) - 1
    if len(numerator) - 1 > n:
        raise SampledModelError("/controller: improper transfer function (numerator degree "
                                f"{len(numerator) - 1} > denominator degree {n})")
    numerator = [0] * (n + 1 - len(numerator)) + numerator
    if method not in ("tustin", "backward_euler"):
        raise SampledModelError(f"/controller/method: {method!r}, expected 'tustin' or "
                                "'backward_euler'")

    def mapped(p):
        out = [0] * (n + 1)
        for i, coefficient in enumerate(p):  # coefficient of s^(n−i)
            power = n - i
            if method == "tustin":  # (2/T)^power (z − 1)^power (z + 1)^(n − power)
                term = linalg.poly_mul(_binomial_power(-1, power), _binomial_power(1, n - power))
                factor = coefficient * (2 / period) ** power
            else:  # (z − 1)^power (T z)^(n − power)
                term = _binomial_power(-1, power) + [0] * (n - power)
                factor = coefficient * period ** (n - power)
            out = linalg.poly_add(out, [factor * t for t in term])
        return out

    return mapped(numerator), mapped(denominator)


def transfer_state_space(numerator: list, denominator: list):
    """(A, B, C, D) of b(z)/a(z) (proper, same length, highest power first) in controllable
    canonical form, as MX, or as DM when every coefficient is a number (a loop of numbers
    then assembles its matrices on numbers: :class:`feedtune.loops.sampled_lti.SampledLTILoop`);
    a static gain gives a 0×0 A."""
    kind = ca.MX if any(isinstance(c, (ca.MX, ca.SX)) for c in [*numerator, *denominator]) else ca.DM
    lead = denominator[0]
    a = [c / lead for c in denominator]
    b = [c / lead for c in numerator]
    n = len(a) - 1
    d = b[0]
    if n == 0:
        return kind(0, 0), kind(0, 1), kind(1, 0), kind(d)
    matrix = linalg.companion_matrix(a)
    c = ca.horzcat(*[b[i + 1] - d * a[i + 1] for i in range(n)])
    b_col = ca.vertcat(1, ca.DM.zeros(n - 1, 1))
    return kind(matrix), kind(b_col), kind(c), kind(d)


def error_controller(numerator: list, denominator: list, period, method: str = "tustin"):
    """u = C(z)·(r − y): a continuous C(s) discretised (:func:`discretise_transfer`)."""
    a, b, c, d = transfer_state_space(*discretise_transfer(numerator, denominator, period, method))
    weights = ca.DM([[1, -1, 0]])  # w = [r, y, v] → e = r − y
    return DiscreteController(a, ca.mtimes(b, weights), c, ca.mtimes(d, weights))


def cascade_controller(position_gain, velocity_numerator: list, velocity_denominator: list,
                       period, method: str = "tustin", feedforward=0.0):
    """P position loop around a velocity controller (e.g. PI K(1 + 1/(T_i s))).

    v_ref = K_p(r − y), u = C_v(z)·(v_ref − v); K_p [1/s], v the sampled velocity C A x.
    With ``feedforward`` k_ff (0 … 1 [1]; True counts as 1) v_ref also carries k_ff times
    the reference's velocity (r(k) − r(k−1))/T, one more state holding r(k−1): with k_ff = 1
    a ramp is followed without steady error.
    """
    a, b, c, d = transfer_state_space(
        *discretise_transfer(velocity_numerator, velocity_denominator, period, method))
    weights = ca.horzcat(position_gain, -position_gain, -1)  # v_ref − v
    if isinstance(feedforward, (bool, int, float)) and float(feedforward) == 0:
        return DiscreteController(a, ca.mtimes(b, weights), c, ca.mtimes(d, weights),
                                  uses_velocity=True)
    # states [x_v, r(k−1)]: e_v = (K_p + k_ff/T) r − K_p y − v − k_ff r(k−1)/T
    rate = feedforward / period
    weights = weights + ca.horzcat(rate, 0, 0)
    order = a.shape[0]
    a_ff = ca.vertcat(ca.horzcat(a, -b * rate), type(a).zeros(1, order + 1))
    b_ff = ca.vertcat(ca.mtimes(b, weights), ca.horzcat(1, 0, 0))
    c_ff = ca.horzcat(c, -d * rate)
    return DiscreteController(a_ff, b_ff, c_ff, ca.mtimes(d, weights), uses_velocity=True)
