"""The model every identification fits: a rational transfer function with integrators and
an input dead time,

    G(s) = b(s) / (s^k a(s)) · e^{−θs},   b(s) = Σ_j b_j s^j,   a(s) = 1 + Σ_i a_i s^i,

from the command to the position (a velocity is s·G). Its frequency response, and its
exact response to a sampled command held between samples (zero-order hold), dead time
included to a fraction of a sample.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import linalg, signal


@dataclass(frozen=True)
class Rational:
    """G(s) = b(s)/(s^k a(s)) e^{−θs} from the command to the position.

    Attributes
    ----------
    numerator : ndarray
        b_0 … b_m, ascending powers of s [position unit/(command unit · s^k)·s^j].
    denominator : ndarray
        1, a_1 … a_n, ascending powers of s (a_0 = 1) [s^i].
    integrators : int
        k, poles at s = 0 of the position response (1 for a drive whose velocity follows
        the command).
    dead_time : float
        θ [s] ≥ 0 at the input.
    """

    numerator: np.ndarray
    denominator: np.ndarray
    integrators: int
    dead_time: float = 0.0

    def response(self, omega: np.ndarray, derivative: int = 0) -> np.ndarray:
        """(jω)^derivative · G(jω) at ω [rad/s]: derivative 1 is the velocity response."""
        s = 1j * np.asarray(omega, dtype=float)
        b = np.polynomial.polynomial.polyval(s, self.numerator)
        a = np.polynomial.polynomial.polyval(s, self.denominator)
        return b / (a * s ** (self.integrators - derivative)) * np.exp(-s * self.dead_time)

    def transfer(self, derivative: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """(numerator, denominator) of s^derivative·G(s) without its dead time, highest
        power first (scipy's and the ``linear`` plant's order); ``derivative`` ≤ k."""
        den = np.concatenate([self.denominator[::-1], np.zeros(self.integrators - derivative)])
        return np.trim_zeros(self.numerator[::-1], "f"), den

    def simulate(self, command: np.ndarray, period: float, derivative: int = 0) -> np.ndarray:
        """s^derivative·G's response at the samples to ``command`` held between them.

        The system starts at rest. With θ = dT + φ (0 ≤ φ < T) the exact step over one
        period is x[k+1] = Φx[k] + Γ₀u[k−d] + Γ₁u[k−d−1], Γ₀ = ∫₀^{T−φ} e^{Aη}dη B,
        Γ₁ = e^{A(T−φ)} ∫₀^φ e^{Aη}dη B (Franklin, Powell & Workman, *Digital Control of
        Dynamic Systems*, §4.3.4), run as one recursive filter (scipy.signal.lfilter).

        Parameters
        ----------
        command : ndarray
            u[k] [command unit], held over [kT, (k+1)T).
        period : float
            T [s].
        """
        num, den = self.transfer(derivative)
        if len(num) >= len(den):
            raise ValueError("the model must be strictly proper (fewer zeros than poles)")
        a, b, c, _ = signal.tf2ss(num, den)
        n = a.shape[0]
        whole = int(np.floor(self.dead_time / period + 1e-12))
        fraction = self.dead_time - whole * period
        phi = _held(a, b, period)[0]
        lead, gamma_late = _held(a, b, period - fraction)
        gamma_early = lead @ _held(a, b, fraction)[1]
        # y(z)/u(z) = C (zI − Φ)⁻¹ (Γ₀ + Γ₁ z⁻¹) z^{−d}; both as polynomials in z⁻¹
        den_z = np.poly(phi)
        num0 = _numerator(phi, gamma_late, c, den_z)
        num1 = _numerator(phi, gamma_early, c, den_z)
        num_z = np.append(num0, 0.0) + np.insert(num1, 0, 0.0)
        den_z = np.append(den_z, 0.0)
        u = np.concatenate([np.zeros(whole), np.asarray(command, dtype=float)])[:len(command)]
        return signal.lfilter(num_z, den_z, u)


def _held(a: np.ndarray, b: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
    """(e^{At}, ∫₀ᵗ e^{Aη}dη B) from one exponential of [[A, B], [0, 0]]·t."""
    n, m = b.shape
    block = np.zeros((n + m, n + m))
    block[:n, :n], block[:n, n:] = a * t, b * t
    e = linalg.expm(block)
    return e[:n, :n], e[:n, n:]


def _numerator(phi: np.ndarray, gamma: np.ndarray, c: np.ndarray, den: np.ndarray) -> np.ndarray:
    """Coefficients of C adj(zI − Φ) Γ in z (highest first), from det(zI − Φ + ΓC) −
    det(zI − Φ) (the rank-one determinant identity)."""
    return (np.poly(phi - gamma @ c) - den).real
