"""The closed loop of a user-defined drive: a :class:`TransferLoop` with a dead time and a
velocity feed-forward.

The polynomials (characteristic polynomial, stability conditions, time responses) hold the
dead time e^{−sθ} as its Padé approximant of order :data:`PADE_ORDER`; the frequency
responses (M_peak, bandwidth, margins, crossover) use e^{−jωθ} exactly, evaluated block by
block at s = jω (:class:`Blocks`). A velocity feed-forward changes the reference path only:
T = (C_p + k_ff s)·Y/V over the same characteristic polynomial
(:func:`feedtune.plants.cascade.close_loops`).

References
----------
G. A. Baker, P. Graves-Morris, "Padé Approximants", 2nd ed., Cambridge University Press,
1996, §1.2 (the diagonal [n/n] approximant of e^{−x}).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from feedtune.expr import to_float
from feedtune.lazy import ca, np
from feedtune.loops import linalg
from feedtune.loops.loop import TransferLoop
from feedtune.loops.protocols import Capability

#: Order n of the [n/n] Padé approximant of e^{−sθ} in the polynomials. Its gain is exactly
#: 1 at every ω; its phase error at x = ωθ is 3.8e-8 rad at x = 1 and 1.8e-5 rad (0.001°)
#: at x = 2 (python-control's ``pade``, tests/unit/test_linear_plant.py). A delay costs
#: ωθ rad of phase at the crossover, so a loop with a positive phase margin has
#: ω_c θ < π/2 and a bandwidth below ≈ 2/θ: order 4 keeps the approximation below 2e-5 rad
#: where the loop's dynamics live, and adds only 4 poles to the characteristic polynomial
#: (order 6 would give 1e-9 rad at x = 2 for a worse-conditioned Hurwitz test).
PADE_ORDER = 4


def pade(dead_time: float, order: int = PADE_ORDER) -> tuple[list, list]:
    """(numerator, denominator) of the [n/n] Padé approximant of e^{−sθ}, highest power first.

    Coefficient of s^k: (2n − k)! n! / ((2n)! k! (n − k)!) · (∓θ)^k (Baker §1.2); θ = 0 gives 1.
    θ may be an expression (a robust scenario's dead time, never 0 there).
    """
    if isinstance(dead_time, (int, float)) and dead_time == 0:
        return [1.0], [1.0]
    c = [math.factorial(2 * order - k) * math.factorial(order)
         / (math.factorial(2 * order) * math.factorial(k) * math.factorial(order - k))
         * dead_time**k for k in range(order + 1)]
    numerator = [(-1) ** k * c[k] for k in range(order, -1, -1)]
    return numerator, c[::-1]


def _value(p: list, omega) -> tuple:
    return linalg.poly_at_jw(p, omega)


def _mul(a: tuple, b: tuple) -> tuple:
    return a[0] * b[0] - a[1] * b[1], a[0] * b[1] + a[1] * b[0]


def _div(a: tuple, b: tuple) -> tuple:
    d2 = b[0] ** 2 + b[1] ** 2
    return (a[0] * b[0] + a[1] * b[1]) / d2, (a[1] * b[0] - a[0] * b[1]) / d2


def _add(a: tuple, b: tuple) -> tuple:
    return a[0] + b[0], a[1] + b[1]


def _scale(a: tuple, k) -> tuple:
    return a[0] * k, a[1] * k


@dataclass(frozen=True)
class Blocks:
    """The loop's blocks without the dead time, for exact frequency responses.

    Drive: velocity per input n_g/d_g·e^{−sθ}, position per input n_x/(q·d_g)·e^{−sθ};
    controllers (K, n, d) as in :func:`feedtune.plants.cascade.close_loops`.
    """

    n_g: list
    d_g: list
    n_x: list
    q: list
    dead_time: float
    position: tuple
    velocity: tuple | None
    feedforward: float

    def response(self, omega, which: str) -> tuple:
        """L (``open``), T (``closed``: position/reference), the error per reference
        (``error``) or the feedback loop's sensitivity S = 1/(1 + L) (``sensitivity``; the
        error per reference only without feed-forward) at s = jω, as an (re, im) pair.

        The polynomial forms of :func:`~feedtune.plants.cascade.close_loops` with e^{−jωθ}
        wherever the drive's numerator is, so T and S are quotients of values that stay
        finite at ω = 0 (no block's pole at s = 0 is divided by).
        """
        delay = (ca.cos(omega * self.dead_time), -ca.sin(omega * self.dead_time))
        kp, n_cp, d_cp = self.position
        a = _scale(_value(n_cp, omega), kp)
        b = _value(d_cp, omega)
        x = _mul(_value(self.n_x, omega), delay)
        q, d_g = _value(self.q, omega), _value(self.d_g, omega)
        if self.velocity is None:
            numerator = _mul(a, x)
            denominator = _mul(b, _mul(q, d_g))
            closed = _add(denominator, numerator)
            pairs = {"open": (numerator, denominator), "closed": (numerator, closed),
                     "error": (denominator, closed), "sensitivity": (denominator, closed)}
            return _div(*pairs[which])
        kv, n_cv, d_cv = self.velocity
        c = _scale(_value(n_cv, omega), kv)
        to_position = _mul(c, x)
        inner = _add(_mul(_value(d_cv, omega), d_g),
                     _mul(c, _mul(_value(self.n_g, omega), delay)))
        numerator = _mul(a, to_position)
        denominator = _mul(b, _mul(q, inner))
        closed = _add(denominator, numerator)
        if which == "open":
            return _div(numerator, denominator)
        if which == "sensitivity":
            return _div(denominator, closed)
        if which == "closed":
            return _div(_mul(_add(a, _scale(_mul((0, omega), b), self.feedforward)),
                             to_position), closed)
        return _div(_mul(b, _add(_mul(q, inner),
                                 _scale(_mul((0, omega), to_position), -self.feedforward))), closed)


@dataclass(frozen=True, eq=False)
class LinearLoop(TransferLoop):
    """A :class:`TransferLoop` whose open loop may hold a dead time and whose reference path
    may hold a velocity feed-forward.

    Attributes
    ----------
    error_numerator
        Error per reference over the characteristic polynomial when a feed-forward makes it
        differ from ``open_denominator`` (else None).
    blocks : Blocks or None
        The blocks without the dead time, when there is one (exact frequency responses).
    loop_type : int
        Integrators in the open loop (1 or more).
    """

    error_numerator: list | None = None
    blocks: Blocks | None = None
    loop_type: int = 1

    @property
    def _error_numerator(self) -> list:
        return self.open_denominator if self.error_numerator is None else self.error_numerator

    @property
    def velocity_constant(self):
        """C_v = lim s·L(s) [1/s] (Bhatia Ch. IV eq 2) of a type-1 loop; a loop of type 2 or
        more has none (C_v = ∞: it follows a ramp without steady error)."""
        if self.loop_type > 1:
            raise ValueError("a loop of type 2 or more has no finite velocity constant")
        return super().velocity_constant

    def offers(self, capability: Capability) -> bool:
        """As every loop (:class:`feedtune.loops.protocols.DeclaredCapabilities`); a loop of type
        2 or more offers no velocity constant."""
        if capability is Capability.VELOCITY_CONSTANT and self.loop_type > 1:
            return False
        return super().offers(capability)

    def open_loop_response(self, omega):
        """Re and Im of L(jω), ω [rad/s]; the dead time exact."""
        if self.blocks is None:
            return super().open_loop_response(omega)
        return self.blocks.response(omega, "open")

    def frequency_response(self, omega):
        """Re and Im of position/reference at s = jω; dead time and feed-forward exact."""
        if self.blocks is not None:
            return self.blocks.response(omega, "closed")
        if self.error_numerator is None:
            return super().frequency_response(omega)
        reference = linalg.poly_add(self.closed_denominator,
                                    linalg.poly_scale(self.error_numerator, -1))
        return self._ratio(reference, self.closed_denominator, omega)

    def error_response(self, omega):
        """Re and Im of S = 1 − T at s = jω, without cancellation at low ω."""
        if self.blocks is not None:
            return self.blocks.response(omega, "error")
        return self._ratio(self._error_numerator, self.closed_denominator, omega)

    def sensitivity_response(self, omega):
        """Re and Im of the feedback loop's S = 1/(1 + L) = den L/(den L + num L) at s = jω,
        whatever the feed-forward (which changes the error per reference, not S)."""
        if self.blocks is not None:
            return self.blocks.response(omega, "sensitivity")
        return self._ratio(self.open_denominator, self.closed_denominator, omega)

    def numeric_transfer(self, output: str = "position", input: str = "reference"):
        """As :meth:`TransferLoop.numeric_transfer`, with the feed-forward's reference path
        (and the dead time as its Padé approximant)."""
        if self.error_numerator is None or input != "reference":
            return super().numeric_transfer(output, input)
        den = np.array([to_float(c) for c in self.closed_denominator])
        error = np.array([to_float(c) for c in self.error_numerator])
        if output == "error":
            return error, den
        return np.polysub(den, error), den
