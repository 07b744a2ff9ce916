"""A tuned loop as python-control systems with named signals.

:meth:`feedtune.Result.to_control` rebuilds the tuned loop from the spec embedded in a
result and the tuned values, with numbers, and :func:`loop_to_control` exports it:

* the closed loop T, ``reference`` → ``position``;
* the open loop L, ``error`` → ``position``, with T = L/(1 + L) (unity feedback);
* the error transfer S = 1 − T, ``reference`` → ``error`` (reference − position);
* for drives with a load input, ``load_torque`` → ``position``.

Positions are in metres (linear axes, ``software_servo``) or radians (rotary axes,
``hydraulic_rotary``, ``ward_leonard``): ``ControlSystems.position_unit`` says which.

Sampled loops (``software_servo`` with ``technique: sampled_data`` and ``model: exact``,
and ``linear`` with ``implementation: sampled``, its drive in s or a discrete model)
export as discrete-time systems with ``dt`` = the sampling period [s]: they map the
position reference at the sampling instants to the position at the sampling instants
(the zero-order hold and the drive discretised exactly; intersample motion is not in a
discrete system). Their state is [drive states, controller states, the commands still in
the computation delay buffer and the dead time], so a delay of d samples adds d states.
The open loop of a sampled ``linear`` loop is the loop opened at the controller's sampled
position, its inner velocity loop closed (Bhatia Fig 18); with a velocity feed-forward
the closed loop is not L/(1 + L), as for the continuous cascade. Continuous loops
(``reference_pulse``, Sato's ``pade`` model, the cascades) export with ``dt = 0``.

A linear interpolator (``interpolation: linear``) sits in front of the servo loop and is
not part of the export: the systems start at the servo's position reference.

Each system carries its name (``closed_loop``, ``open_loop``, ``error``, ``load``) and
its signals' names, so ``control.interconnect`` and ``control.feedback`` can connect them
by name.

This module sits beside the data flow of docs/design.md (plant → Loop → metrics → tuner):
it reads a plant's Loop, and nothing in feedtune imports it but :mod:`feedtune.api`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from feedtune.expr import is_symbolic, to_array
from feedtune.loops.loop import ContinuousLoop, SampledLoop, TransferLoop
from feedtune.loops.pulse_train import PulseLoop
from feedtune.loops.sampled_lti import SampledLTILoop

#: the open loop rebuilt from a state-space closed loop must give the loop's own velocity
#: constant to this relative tolerance, or the loop is not the unity-feedback loop assumed
OPEN_LOOP_CHECK_RTOL = 1e-6

#: the signals' names: position reference and position [m or rad], position error
#: (reference − position) [m or rad], load torque [N·m]
REFERENCE, POSITION, ERROR, LOAD_TORQUE = "reference", "position", "error", "load_torque"


class ResultError(ValueError):
    """A file that cannot be used as a feedtune result; the message names the file."""


@dataclass(frozen=True)
class ControlSystems:
    """The tuned loop as python-control systems.

    Attributes
    ----------
    closed_loop : control.StateSpace or control.TransferFunction
        T, named ``closed_loop``: ``reference`` [m or rad] → ``position`` [m or rad]; DC
        gain 1.
    open_loop : control.StateSpace or control.TransferFunction
        L, named ``open_loop``: ``error`` [m or rad] → ``position`` [m or rad], type 1 (one
        integrator), with ``closed_loop`` = L/(1 + L) (not with a velocity feed-forward,
        whose reference path differs). Margins
        (``control.stability_margins``) and the velocity constant C_v = lim s·L(s) [1/s]
        are read from it.
    error : control.StateSpace or control.TransferFunction
        S = 1 − T, named ``error``: ``reference`` [m or rad] → ``error`` [m or rad].
    load : control.TransferFunction or None
        Named ``load``: ``load_torque`` [N·m] → ``position`` [rad], for a drive with a load
        path (Bhatia's ``hydraulic_rotary`` with K_ce, V_t and β_e given,
        ``ward_leonard``), else None.
    dt : float
        Sampling period [s] of a discrete export, 0 for a continuous one (python-control's
        convention, the same ``dt`` every system here carries).
    position_unit : str
        ``"m"`` or ``"rad"``.
    """

    closed_loop: Any
    open_loop: Any
    error: Any
    load: Any
    dt: float
    position_unit: str

    @property
    def discrete(self) -> bool:
        """True for a sampled loop's export (``dt`` > 0)."""
        return self.dt != 0


def loop_to_control(loop, position_unit: str = "m") -> ControlSystems:
    """python-control systems of a feedtune Loop whose numbers are numbers (no symbols).

    Parameters
    ----------
    loop : ContinuousLoop, SampledLoop, SampledLTILoop or TransferLoop
    position_unit : str
        ``"m"`` or ``"rad"``, recorded in the result.

    Returns
    -------
    ControlSystems
        Named systems with named signals (``reference``, ``position``, ``error``,
        ``load_torque``).

    Raises
    ------
    TypeError
        A loop kind with no linear export (a pulse simulation).
    ValueError
        A state-space loop that is not unity feedback of its position error.
    """
    import control  # deferred: only exports need python-control

    def tf(num, den, name, input_=REFERENCE, output=POSITION):
        return control.tf(num, den, name=name, inputs=input_, outputs=output)

    if isinstance(loop, TransferLoop):
        # the cascade (Bhatia Fig 18/33) and Sato's Padé loop are polynomials in s; the
        # closed loop and error from the loop's own reference path (a user's velocity
        # feed-forward changes it; a dead time is its Padé approximant)
        num, den = _polynomial(loop.open_numerator), _polynomial(loop.open_denominator)
        reference, closed = loop.numeric_transfer("position", "reference")
        error, _ = loop.numeric_transfer("error", "reference")
        load = None
        if loop.load_numerator is not None:
            load = tf(_polynomial(loop.load_numerator), closed, "load", input_=LOAD_TORQUE)
        return ControlSystems(closed_loop=tf(reference, closed, "closed_loop"),
                              open_loop=tf(num, den, "open_loop", input_=ERROR),
                              error=tf(error, closed, "error", output=ERROR), load=load,
                              dt=0.0, position_unit=position_unit)
    if isinstance(loop, SampledLTILoop):
        # the loop's own open loop (SampledLTILoop.open_loop_response): cut at the
        # controller's sampled position input w, L = −C(zI − Φ_o)⁻¹Γ_w; no feedthrough (the
        # command of sample k moves the position from sample k + 1 on)
        a, b = _matrix(loop.state_matrix), _matrix(loop.input_matrix).reshape(-1, 1)
        c = _matrix(loop.position_row).reshape(1, -1)
        open_a, cut = (_matrix(m) for m in loop.open_loop_matrices)
        dt, zero = _scalar(loop.period), np.zeros((1, 1))

        def ss(a, b, c, d, name, input_=REFERENCE, output=POSITION):
            return control.ss(a, b, c, d, dt, name=name, inputs=input_, outputs=output)

        return ControlSystems(closed_loop=ss(a, b, c, zero, "closed_loop"),
                              open_loop=ss(open_a, -cut.reshape(-1, 1), c, zero, "open_loop",
                                           input_=ERROR),
                              error=ss(a, b, -c, np.ones((1, 1)), "error", output=ERROR),
                              load=None, dt=dt, position_unit=position_unit)
    if isinstance(loop, (ContinuousLoop, SampledLoop)):
        a = _matrix(loop.state_matrix)
        b = _matrix(loop.input_matrix).reshape(-1, 1)
        c = _matrix(loop.position_row).reshape(1, -1)
        dt = _scalar(loop.period) if isinstance(loop, SampledLoop) else 0.0
        # Koren's loops (Figs 2 and 4) are unity feedback of the position error: the state
        # moves as x' = A_L x + B (r − C x), so A = A_L − B C and the open loop is
        # (A + B C, B, C). A delayed sample's commands are states of both.
        open_a = a + b @ c
        _check_open_loop(open_a, b, c, dt, _scalar(loop.velocity_constant), type(loop).__name__)
        zero = np.zeros((1, 1))

        def ss(a, b, c, d, name, input_=REFERENCE, output=POSITION):
            return control.ss(a, b, c, d, dt, name=name, inputs=input_, outputs=output)

        return ControlSystems(closed_loop=ss(a, b, c, zero, "closed_loop"),
                              open_loop=ss(open_a, b, c, zero, "open_loop", input_=ERROR),
                              error=ss(a, b, -c, np.ones((1, 1)), "error", output=ERROR),
                              load=None, dt=dt, position_unit=position_unit)
    if isinstance(loop, PulseLoop):  # exact_only: no linear model
        raise TypeError(f"a {type(loop).__name__} is a discrete pulse simulation, not a linear "
                        "system: it has no python-control export")
    raise TypeError(f"no python-control export for a {type(loop).__name__}")


def closed_loop_state_space(loop) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                             float]:
    """The closed loop T (reference → position) of a Loop of numbers as float matrices,
    without python-control: ``(A, B, C, D, dt)``, the same system as
    :func:`loop_to_control`'s ``closed_loop`` (``dt`` = the sampling period [s] of a sampled
    loop, 0 for a continuous one; B a column, C a row, D 1×1).

    A polynomial loop (``TransferLoop``) is put in controllable canonical form
    (``scipy.signal.tf2ss``) and balanced by a diagonal power-of-two similarity
    (``scipy.linalg.matrix_balance``, exact), so its exponential keeps its digits at
    Bhatia's coefficients (1e11 beside 1).

    Raises
    ------
    TypeError
        A loop kind with no linear model (a pulse simulation).
    """
    from scipy.linalg import matrix_balance
    from scipy.signal import tf2ss

    if isinstance(loop, TransferLoop):
        num, den = (np.trim_zeros(p, "f") for p in loop.numeric_transfer("position",
                                                                         "reference"))
        a, b, c, d = tf2ss(num, den)
        _, (scale, _) = matrix_balance(a, permute=False, separate=True)
        return (a * (1 / scale)[:, None] * scale[None, :], b / scale[:, None],
                c * scale[None, :], np.atleast_2d(d).astype(float), 0.0)
    if isinstance(loop, (SampledLTILoop, ContinuousLoop, SampledLoop)):
        a, b = _matrix(loop.state_matrix), _matrix(loop.input_matrix).reshape(-1, 1)
        c = _matrix(loop.position_row).reshape(1, -1)
        dt = 0.0 if isinstance(loop, ContinuousLoop) else _scalar(loop.period)
        return a, b, c, np.zeros((1, 1)), dt
    if isinstance(loop, PulseLoop):
        raise TypeError(f"a {type(loop).__name__} is a discrete pulse simulation, not a linear "
                        "system")
    raise TypeError(f"no state-space closed loop for a {type(loop).__name__}")


def _check_open_loop(a, b, c, dt, velocity_constant, kind) -> None:
    """The rebuilt open loop must be type 1 with the loop's own C_v [1/s].

    C_v = lim s·L(s) (continuous) or lim (z − 1)/T·L(z) (sampled) is the residue at the
    integrator: with v, w the right and left eigenvectors of the eigenvalue 0 (or 1),
    C_v = (C v)(w B)/(w v), divided by T for a sampled loop.
    """
    target = 1.0 if dt else 0.0
    eigenvalues, right = np.linalg.eig(a)
    k = int(np.argmin(np.abs(eigenvalues - target)))
    scale = max(1.0, float(np.max(np.abs(eigenvalues))))
    if abs(eigenvalues[k] - target) > 1e-9 * scale:
        raise ValueError(f"{kind}: the rebuilt open loop has no integrator (nearest pole "
                         f"{eigenvalues[k]:.6g}); the loop is not unity feedback of its error")
    v = right[:, k]
    left = np.linalg.svd(a - target * np.eye(a.shape[0]))[0][:, -1].conj()  # w (A − λI) = 0
    residue = (c @ v).item() * (left @ b).item() / (left @ v)
    found = float(np.real(residue)) / (dt if dt else 1.0)
    if not np.isclose(found, velocity_constant, rtol=OPEN_LOOP_CHECK_RTOL, atol=0):
        raise ValueError(f"{kind}: the open loop rebuilt by unity feedback has C_v = {found:.9g} "
                         f"1/s, the loop's own is {velocity_constant:.9g} 1/s; it has no "
                         "unity-feedback open loop to export")


def _numbers(x) -> np.ndarray:
    if is_symbolic(x):
        raise ValueError("the loop still holds symbols; build it with numbers")
    return to_array(x)


def _matrix(x) -> np.ndarray:
    return np.atleast_2d(_numbers(x))


def _scalar(x) -> float:
    return float(_numbers(x).reshape(-1)[0])


def _polynomial(coefficients) -> np.ndarray:
    """Float coefficients, highest power first, leading exact zeros dropped."""
    p = np.array([_scalar(c) for c in coefficients])
    nonzero = np.flatnonzero(p)
    return p[nonzero[0]:] if nonzero.size else np.zeros(1)
