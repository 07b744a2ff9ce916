"""Continue from a result in python-control: rebuild the tuned loop and export it.

:func:`load_result` reads a result JSON that ``feedtune tune`` (or ``feedtune batch``)
wrote; :meth:`LoadedResult.to_control` rebuilds the tuned loop from the spec embedded in
the result and the tuned values, with numbers, and returns python-control systems:

* the closed loop T, position reference → position;
* the open loop L, position error → position, with T = L/(1 + L) (unity feedback);
* the error transfer S = 1 − T, position reference → position error (reference − position);
* for drives with a load input, position per load torque.

Positions are in metres (linear axes, ``software_servo``) or radians (rotary axes,
``hydraulic_rotary``, ``ward_leonard``): ``ControlSystems.position_unit`` says which.

Sampled loops (``software_servo`` with ``technique: sampled_data`` and ``model: exact``)
export as discrete-time systems with ``dt`` = the sampling period [s]: they map the
position reference at the sampling instants to the position at the sampling instants
(the zero-order hold and the drive discretised exactly; intersample motion is not in a
discrete system). Their state is [drive states, the commands still in the computation
delay buffer], so a delay of d samples adds d states. Continuous loops
(``reference_pulse``, Sato's ``pade`` model, the Bhatia cascades) export with ``dt = 0``.

A linear interpolator (``interpolation: linear``) sits in front of the servo loop and is
not part of the export: the systems start at the servo's position reference.

This module sits beside the data flow of docs/design.md (plant → Loop → metrics → tuner): it
reads a result and a plant's Loop, and nothing in feedtune imports it but the package's
``load_result``.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np
from pydantic import ValidationError

from feedtune.loop import ContinuousLoop, SampledLoop, TransferLoop
from feedtune.plants import plant_for
from feedtune.result import TuneResult
from feedtune.spec import Spec, SpecError, load_json, parse_spec

#: the open loop rebuilt from a state-space closed loop must give the loop's own velocity
#: constant to this relative tolerance, or the loop is not the unity-feedback loop assumed
OPEN_LOOP_CHECK_RTOL = 1e-6


class ResultError(ValueError):
    """A file that cannot be used as a feedtune result; the message names the file."""


@dataclass(frozen=True)
class ControlSystems:
    """The tuned loop as python-control systems.

    Attributes
    ----------
    closed_loop : control.StateSpace or control.TransferFunction
        T: position reference [m or rad] → position [m or rad]; DC gain 1.
    open_loop : control.StateSpace or control.TransferFunction
        L: position error [m or rad] → position [m or rad], type 1 (one integrator), with
        ``closed_loop`` = L/(1 + L). Margins (``control.stability_margins``) and the
        velocity constant C_v = lim s·L(s) [1/s] are read from it.
    error : control.StateSpace or control.TransferFunction
        S = 1 − T: position reference [m or rad] → position error [m or rad].
    load : control.TransferFunction or None
        Position [rad] per load torque [N·m] of a drive with a load path (Bhatia's
        ``hydraulic_rotary`` with K_ce, V_t and β_e given, ``ward_leonard``), else None.
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
        return self.dt != 0


class LoadedResult:
    """A :class:`~feedtune.result.TuneResult` read from a file, ready to rebuild its loop.

    Attributes
    ----------
    result : TuneResult
        The result as written (the pure data model).
    path : Path or None
        The file it was read from.
    """

    def __init__(self, result: TuneResult, path: Path | str | None = None):
        self.result = result
        self.path = Path(path) if path is not None else None

    def __repr__(self) -> str:
        return f"LoadedResult({self.result.name!r}, status={self.result.status!r}, path={self.path})"

    def _where(self) -> str:
        return str(self.path) if self.path is not None else f"result {self.result.name!r}"

    @cached_property
    def spec(self) -> Spec:
        """The spec that was solved, parsed from the copy embedded in the result."""
        try:
            return parse_spec(dict(self.result.spec))
        except SpecError as exc:
            raise ResultError(f"{self._where()}: the embedded spec is not valid for this "
                              f"feedtune: {exc}") from None

    @property
    def values(self) -> dict[str, float]:
        """Tuned value of every tunable [its unit], fixed ones included."""
        return {name: float(t.value) for name, t in self.result.tuned.items()}

    def loop(self):
        """The tuned loop, rebuilt with numbers: the same feedtune Loop the result's
        metrics were evaluated on (the tuner's box is the result's ``min``/``max``)."""
        spec = self.spec
        plant = plant_for(spec.plant)
        tunables = plant.tunables()
        tuned = self.result.tuned
        missing = sorted(set(tunables) - set(tuned))
        if missing:
            raise ResultError(
                f"{self._where()}: no tuned value for {', '.join(missing)} (status "
                f"{self.result.status}: {self.result.message})")
        values, box = {}, {}
        for name, tunable in tunables.items():
            t = tuned[name]
            values[name] = float(t.value)
            box[name] = (float(t.min if t.min is not None else min(tunable.min, t.value)),
                         float(t.max if t.max is not None else max(tunable.max, t.value)))
        return plant.loop(values, box)

    def to_control(self) -> ControlSystems:
        """The tuned loop as python-control systems (see :class:`ControlSystems`).

        Works for any result with tuned values, including an unstable or infeasible one
        (python-control will show why); a result of a failed build has none and raises.

        Raises
        ------
        ResultError
            The result has no tuned values, or its embedded spec is not valid.
        TypeError
            A loop kind this module does not know how to export.
        ValueError
            A state-space loop that is not the unity-feedback loop its open loop is
            rebuilt from (its own velocity constant disagrees).
        """
        loop = self.loop()
        unit = getattr(plant_for(self.spec.plant), "position_unit", "m")
        return loop_to_control(loop, unit)


def loop_to_control(loop, position_unit: str = "m") -> ControlSystems:
    """python-control systems of a feedtune Loop whose numbers are numbers (no symbols).

    Parameters
    ----------
    loop : ContinuousLoop, SampledLoop or TransferLoop
    position_unit : str
        ``"m"`` or ``"rad"``, recorded in the result.
    """
    import control  # deferred: only exports need python-control

    if isinstance(loop, TransferLoop):
        # the cascade (Bhatia Fig 18/33) and Sato's Padé loop are polynomials in s; the
        # closed loop and error from the loop's own reference path (a user's velocity
        # feed-forward changes it; a dead time is its Padé approximant)
        num, den = _polynomial(loop.open_numerator), _polynomial(loop.open_denominator)
        reference, closed = loop.numeric_transfer("position", "reference")
        error, _ = loop.numeric_transfer("error", "reference")
        load = None
        if loop.load_numerator is not None:
            load = control.tf(_polynomial(loop.load_numerator), closed)
        return ControlSystems(closed_loop=control.tf(reference, closed),
                              open_loop=control.tf(num, den), error=control.tf(error, closed),
                              load=load, dt=0.0, position_unit=position_unit)
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
        return ControlSystems(closed_loop=control.ss(a, b, c, zero, dt),
                              open_loop=control.ss(open_a, b, c, zero, dt),
                              error=control.ss(a, b, -c, np.ones((1, 1)), dt),
                              load=None, dt=dt, position_unit=position_unit)
    if getattr(loop, "exact_only", False):
        raise TypeError(f"a {type(loop).__name__} is a discrete pulse simulation, not a linear "
                        "system: it has no python-control export")
    raise TypeError(f"no python-control export for a {type(loop).__name__}")


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
    value = ca.MX(x) if not isinstance(x, (ca.MX, ca.SX)) else x
    if value.is_symbolic() or ca.symvar(ca.vec(value)):
        raise ValueError("the loop still holds symbols; build it with numbers")
    return np.array(ca.evalf(value), dtype=float)


def _matrix(x) -> np.ndarray:
    return np.atleast_2d(_numbers(x))


def _scalar(x) -> float:
    return float(_numbers(x).reshape(-1)[0])


def _polynomial(coefficients) -> np.ndarray:
    """Float coefficients, highest power first, leading exact zeros dropped."""
    p = np.array([_scalar(c) for c in coefficients])
    nonzero = np.flatnonzero(p)
    return p[nonzero[0]:] if nonzero.size else np.zeros(1)


def load_result(path: str | Path) -> LoadedResult:
    """Read a result JSON written by ``feedtune tune`` (or one of ``feedtune batch``'s).

    Returns
    -------
    LoadedResult
        ``.result`` (the TuneResult), ``.loop()`` (the tuned feedtune Loop) and
        ``.to_control()`` (python-control systems: closed loop position reference →
        position, open loop, error; discrete with ``dt`` = the sampling period for a
        sampled loop).

    Raises
    ------
    FileNotFoundError
        No file at ``path``.
    ResultError
        The file is not UTF-8 JSON, or not a feedtune result (a spec, a batch summary);
        the message names the file.
    """
    path = Path(path)
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise FileNotFoundError(f"{path}: no such result file") from None
    except IsADirectoryError:
        raise ResultError(f"{path}: is a directory, not a result file") from None
    try:  # the specs' strict reader: UTF-8, no NaN, no duplicate keys, size-limited
        data = load_json(raw)
    except SpecError as exc:
        raise ResultError(f"{path}: {exc}") from None
    if not isinstance(data, dict):
        raise ResultError(f"{path}: a result is a JSON object, not {type(data).__name__}")
    if "tuned" not in data and "plant" in data:
        raise ResultError(f"{path}: this is a spec, not a result; run `feedtune tune {path} "
                          "-o RESULT` and load RESULT")
    try:
        result = TuneResult.model_validate(data)
    except ValidationError as exc:
        problems = "; ".join(f"/{'/'.join(str(p) for p in e['loc'])}: {e['msg']}"
                             for e in exc.errors()[:5])
        more = f" (and {exc.error_count() - 5} more)" if exc.error_count() > 5 else ""
        raise ResultError(f"{path}: not a feedtune result: {problems}{more}") from None
    return LoadedResult(result, path)

