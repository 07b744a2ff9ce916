"""The Python API: build a spec in code (or read one), tune it, get a :class:`Result` back.

``feedtune.tune(spec)`` is what ``feedtune tune SPEC`` runs: the command line calls
:func:`tune` and writes :meth:`Result.to_json`, so both give the same bytes (apart from
the solver's times). ``feedtune.load_result(path)`` reads a result JSON back into the
same :class:`Result`.

This module sits beside the data flow of docs/design.md (plant → Loop → metrics → tuner):
it calls :func:`feedtune.problem.tune`, the validator, the report and the python-control
export, and nothing in feedtune imports it but the package's lazy attributes and the
command line.
"""

from __future__ import annotations

import contextlib
import gc
import os
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any, Callable, Iterator, Mapping

from pydantic import ValidationError

from feedtune.loops.export import ControlSystems, ResultError, loop_to_control
from feedtune.plants import plant_for
from feedtune.schema.files import write_atomic
from feedtune.schema.labels import metric_label
from feedtune.schema.result import (ConstraintResult, MetricValue, OptimumCheck, TunedValue,
                                    TuneResult)
from feedtune.schema.spec import MAX_SPEC_BYTES, Spec, SpecError, load_json, parse_spec

__all__ = ["ControlSystems", "ReportFiles", "Result", "ResultError", "Spec", "SpecError",
           "load_result", "tune"]


def tune(spec: Spec | Mapping[str, Any] | str | os.PathLike, *,
         progress: Callable[[Any, int], None] | None = None,
         notify: Callable[[str], None] | None = None,
         threads: int | None = 1) -> Result:
    """Solve a tuning problem, as ``feedtune tune`` does, and return its :class:`Result`.

    Parameters
    ----------
    spec : Spec, dict or path
        The problem: a :class:`Spec` built in code, a dict of the spec's JSON form (see
        ``feedtune schema``; SI units: gains [1/s], periods [s], lengths [m]), or the path
        (str or path-like) of a spec JSON file. Every form is checked as ``feedtune
        validate`` checks a file, so a ``Spec`` built in code is refused for exactly what
        a file would be.
    progress : callable, optional
        ``progress(start, total)`` after each multistart start; ``start`` has ``index``
        (0-based), ``status``, ``objective``, ``iterations`` [count] and ``solve_time`` [s].
    notify : callable, optional
        ``notify(text)`` with a sentence for people when the problem is solved again (a
        longer step-response horizon, a whole interpolation ratio).
    threads : int or None, default 1
        BLAS threads of numpy and scipy during the call [count], restored afterwards;
        None leaves them as they are. The tuner and the validator run many small matrix
        operations, for which a second thread only adds synchronisation: Bhatia's example
        took twice the CPU time on 2 threads (README, "Python API").

    Returns
    -------
    Result
        Whatever happened: a failed solve is a result with ``success`` false and the
        solver's status, never an exception.

    Raises
    ------
    SpecError
        The spec cannot be used; ``errors`` lists (JSON pointer, message) for every
        problem, as ``feedtune validate`` prints them.
    FileNotFoundError, IsADirectoryError, PermissionError
        ``spec`` is a path that cannot be read.
    TypeError
        ``spec`` is of another type, or a str holding JSON text rather than a path.

    Examples
    --------
    >>> import feedtune
    >>> result = feedtune.tune({
    ...     "name": "koren-sampled",
    ...     "plant": {"type": "software_servo", "technique": "sampled_data",
    ...               "time_constant": 0.02, "blu": 5e-6, "max_velocity": 0.04},
    ...     "tunables": {"position_gain": {"min": 1, "max": 200},
    ...                  "sampling_period": {"value": 0.015625}},
    ...     "objective": [{"metric": "radial_error", "radius": 0.008, "feed": 0.04}],
    ...     "constraints": [{"metric": "damping_ratio", "min": 0.5}],
    ...     "solver": {"multistart": 2}})
    >>> result.status, round(result.values["position_gain"], 2)   # K [1/s]
    ('optimal', 18.17)
    """
    parsed = as_spec(spec)
    from feedtune.problem import tune as solve  # the tuner: loaded on first use

    with blas_threads(threads), older_objects_unscanned():
        return Result(solve(parsed, progress=progress, notify=notify))


def as_spec(spec: Spec | Mapping[str, Any] | str | os.PathLike) -> Spec:
    """A checked :class:`Spec` from any form :func:`tune` takes (see there).

    Raises
    ------
    SpecError
        With (JSON pointer, message) for every problem.
    TypeError
        ``spec`` is none of the forms (bytes included: give a path or a dict), or a str
        holding JSON text rather than a path.
    """
    if isinstance(spec, Spec):  # built in code: the registry checks have not run yet
        return parse_spec(spec.model_dump(mode="json"))
    if isinstance(spec, Mapping):
        return parse_spec(dict(spec))
    if isinstance(spec, str) and spec.lstrip().startswith("{"):
        raise TypeError("a str is the path of a spec file; for JSON text give "
                        "json.loads(text) or feedtune.Spec.model_validate_json(text)")
    if isinstance(spec, (str, os.PathLike)):
        with open(spec, "rb") as handle:  # the caller's path, never one from a spec
            data = handle.read(MAX_SPEC_BYTES + 1)
        if len(data) > MAX_SPEC_BYTES:
            raise SpecError([("", f"{os.fspath(spec)}: spec is larger than the limit of "
                                  f"{MAX_SPEC_BYTES} bytes")])
        return parse_spec(data)
    from feedtune.measured.datadriven_spec import DataDrivenSpec  # loads numpy: asked last

    if isinstance(spec, DataDrivenSpec):  # a spec of measured data (the convex technique)
        return parse_spec(spec.model_dump(mode="json"))
    raise TypeError(f"a spec is a feedtune.Spec, a dict or the path of a JSON file, not "
                    f"{type(spec).__name__}")


@contextlib.contextmanager
def older_objects_unscanned() -> Iterator[None]:
    """The objects alive before the call (the imported modules, the caller's) left out of
    the garbage collector's scans meanwhile (``gc.freeze``), given back to its oldest
    generation after (``gc.unfreeze``); nothing is done if the caller froze objects itself.

    A tuning allocates enough objects to trigger one full collection in a fresh process,
    which then walks the ≈ 95 000 objects of the imports (numpy, scipy, casadi, pydantic):
    ≈ 0.05–0.06 s of CPU of a cold 0.5 s tuning of ``examples/user-defined-pid-notch.json``
    (benchmarks/README.md, "Branch h-cold4"). The tuning's own objects are still collected
    as before; the older ones are scanned again by the caller's next full collection.
    """
    if gc.get_freeze_count():
        yield
        return
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


@contextlib.contextmanager
def blas_threads(threads: int | None) -> Iterator[None]:
    """numpy's and scipy's BLAS on ``threads`` threads [count] meanwhile, restored after
    (None: unchanged), by threadpoolctl; an OpenBLAS first loaded meanwhile starts on
    ``threads`` too.

    The ``feedtune`` command pins one thread by the environment before numpy loads
    (:func:`feedtune.__main__.pin_blas_threads`); a Python caller has usually imported
    numpy already, so only a library that talks to the loaded BLAS can do it here. CasADi
    loads its own OpenBLAS (``libcasadi-tp-openblas``, which threadpoolctl does not
    recognise) with IPOPT's plugin at a process's first solve; it reads
    ``OPENBLAS_NUM_THREADS`` then, so that is set to ``threads`` during the call unless the
    caller set it, and removed after. Started on a thread per core, its workers spun
    ≈ 0.13 s of CPU on the other core during a cold tuning of
    ``examples/user-defined-pid-notch.json`` (benchmarks/README.md, "Branch h-cold4").
    """
    if threads is None:
        yield
        return
    from threadpoolctl import threadpool_limits

    variable = "OPENBLAS_NUM_THREADS"
    ours = variable not in os.environ
    if ours:
        os.environ[variable] = str(threads)
    try:
        with threadpool_limits(limits=threads, user_api="blas"):
            yield
    finally:
        if ours:
            os.environ.pop(variable, None)


@dataclass(frozen=True)
class ReportFiles:
    """What :meth:`Result.report` wrote.

    Attributes
    ----------
    page : Path
        ``report.html``, self-contained (figures embedded).
    figures : list of Path
        The PNG figures drawn (``responses.png``, ``bode.png``, ...).
    left_out : dict of str to str
        Each figure the plant cannot offer (file stem), with the reason.
    """

    page: Path
    figures: list[Path]
    left_out: dict[str, str]


class Result:
    """The result of a tuning: tuned values, metrics, constraints, status, and what to do
    with them (:meth:`to_json`, :meth:`save`, :meth:`to_control`, :meth:`report`).

    Returned by :func:`tune` and :func:`load_result`. Every number is in SI units, the
    unit of each given beside it (``tuned[name].unit``, ``metrics[key].unit``).

    Parameters
    ----------
    data : TuneResult
        The result's data model (what the JSON holds).
    path : str or Path, optional
        The file it was read from, if any.

    Attributes
    ----------
    data : TuneResult
        Everything the JSON holds, as a pydantic model (``data.solver``,
        ``data.provenance``, ``data.validation`` ...).
    path : Path or None
        The file the result was read from (:func:`load_result`), else None.

    Examples
    --------
    >>> result = feedtune.load_result("result.json")       # doctest: +SKIP
    >>> result.values                                       # doctest: +SKIP
    {'position_gain': 18.173..., 'sampling_period': 0.015625}
    >>> result.metrics["damping_ratio"].value               # doctest: +SKIP
    0.699...
    """

    def __init__(self, data: TuneResult, path: str | os.PathLike | None = None):
        self.data = data
        self.path = Path(path) if path is not None else None

    # -- what the result says ------------------------------------------------------------

    @property
    def name(self) -> str:
        """The spec's name."""
        return self.data.name

    @property
    def success(self) -> bool:
        """True only for a feasible, stable optimum (``feedtune tune`` then exits 0)."""
        return self.data.success

    @property
    def status(self) -> str:
        """``optimal``, ``acceptable``, ``infeasible``, ``iteration_limit``,
        ``time_limit`` or ``error``; the solver's own word is ``data.solver.return_status``."""
        return self.data.status

    @property
    def message(self) -> str:
        """What happened, in words (which start won, why the problem was solved again)."""
        return self.data.message

    @property
    def objective(self) -> float | None:
        """The weighted objective at the tuned point [its terms' units]; None when unstable
        or not solved."""
        return self.data.objective

    @property
    def values(self) -> dict[str, float]:
        """Tuned value of every tunable, fixed ones included [the tunable's unit, see
        :attr:`units`]."""
        return {name: float(t.value) for name, t in self.data.tuned.items()}

    @property
    def units(self) -> dict[str, str]:
        """Unit of every tunable (``"1/s"``, ``"s"``, ``"V·s/rad"`` ...)."""
        return {name: t.unit for name, t in self.data.tuned.items()}

    @property
    def tuned(self) -> dict[str, TunedValue]:
        """Every tunable: ``value`` [unit], ``unit``, ``fixed``, the box searched
        (``min``, ``max``) and the bound the optimum sits on (``at_bound``)."""
        return self.data.tuned

    @property
    def metrics(self) -> dict[str, MetricValue]:
        """Every metric the plant supports at the tuned point, by label (``iae``,
        ``radial_error(radius=0.008,feed=0.04)``): ``value`` [``unit``] (None where undefined,
        and for all when the loop is unstable), ``unit``, ``options``."""
        return self.data.metrics

    @property
    def constraints(self) -> list[ConstraintResult]:
        """Each constraint of the spec: ``metric``, ``options``, ``min``, ``max``,
        ``value`` [the metric's unit] and ``satisfied``."""
        return self.data.constraints

    @property
    def stability(self) -> dict[str, Any]:
        """``stable``, the closed-loop ``poles`` and the spectral radius [1] (sampled) or
        abscissa [1/s] (continuous)."""
        return self.data.stability

    @property
    def optimum(self) -> OptimumCheck | None:
        """Whether the optimum is unique (``unique``, ``flat``, ``spread``, ``advice``);
        None when no start succeeded."""
        return self.data.optimum

    @property
    def warnings(self) -> list[str]:
        """Ways the design is implausible on its own terms (counter overflow, a unit slip);
        ``feedtune tune`` prints each on stderr."""
        return self.data.warnings

    @property
    def validation(self) -> dict[str, Any] | None:
        """The independent re-measurement of every metric (README, "Independent
        validation"); ``validation["ok"]`` is false when a gap exceeds its tolerance."""
        return self.data.validation

    @cached_property
    def spec(self) -> Spec:
        """The spec that was solved, parsed from the copy embedded in the result.

        Raises
        ------
        ResultError
            The embedded spec is not valid for this feedtune (a result of another version).
        """
        try:
            return parse_spec(dict(self.data.spec))
        except SpecError as exc:
            raise ResultError(f"{self._where()}: the embedded spec is not valid for this "
                              f"feedtune: {exc}") from None

    # -- writing ---------------------------------------------------------------------------

    def to_json(self) -> str:
        """The result JSON exactly as ``feedtune tune`` writes it (indented, final newline).

        Returns
        -------
        str
            The same text ``feedtune tune SPEC -o FILE`` writes to FILE for this result.
        """
        return self.data.model_dump_json(indent=2) + "\n"

    def save(self, path: str | os.PathLike) -> Path:
        """Write :meth:`to_json` to ``path`` atomically (a temporary file in the same
        directory, flushed and renamed), as ``feedtune tune -o`` does.

        Parameters
        ----------
        path : str or path-like
            The result file; its directory must exist. A symlink there is replaced, not
            followed.

        Returns
        -------
        Path
            ``path``.

        Raises
        ------
        OSError
            The file cannot be written; nothing is left behind.
        """
        path = Path(path)
        write_atomic(path, self.to_json().encode("utf-8"))
        return path

    def report(self, directory: str | os.PathLike) -> ReportFiles:
        """Draw the report of ``feedtune report`` (and ``feedtune tune --report``) into
        ``directory``: ``report.html`` and the PNG figures (README, "Reports").

        Parameters
        ----------
        directory : str or path-like
            Created if missing; files of other names in it are left alone.

        Returns
        -------
        ReportFiles
            The page, the figures written and those left out with the reason.

        Raises
        ------
        feedtune.report.ReportDirError
            ``directory`` holds a file of a name the report writes that an earlier report
            did not write; nothing is written then.
        """
        from feedtune.cli.plants import plant_parameters
        from feedtune.report import build_figures, write_report

        result = self.data.model_dump(mode="json")
        parameters = plant_parameters(((result.get("spec") or {}).get("plant") or {}).get("type"))
        figures = build_figures(result)
        written = write_report(result, Path(directory), figures, parameters)
        return ReportFiles(page=written[0], figures=written[1:],
                      left_out={stem: why for stem, _, png, why in figures if png is None})

    # -- the loop ----------------------------------------------------------------------------

    def loop(self):
        """The tuned loop, rebuilt with numbers: the same feedtune Loop the result's
        metrics were evaluated on (the tuner's box is the result's ``min``/``max``).

        Raises
        ------
        ResultError
            The result has no tuned values (a failed build), or its spec is not valid.
        """
        if not isinstance(self.spec, Spec):
            raise ResultError(f"{self._where()}: a design on measured frequency responses has "
                              "no model to build a loop from")
        plant = plant_for(self.spec.plant)
        tunables = plant.tunables()
        tuned = self.data.tuned
        missing = sorted(set(tunables) - set(tuned))
        if missing:
            raise ResultError(
                f"{self._where()}: no tuned value for {', '.join(missing)} (status "
                f"{self.data.status}: {self.data.message})")
        values, box = {}, {}
        for name, tunable in tunables.items():
            t = tuned[name]
            values[name] = float(t.value)
            box[name] = (float(t.min if t.min is not None else min(tunable.min, t.value)),
                         float(t.max if t.max is not None else max(tunable.max, t.value)))
        return plant.loop(values, box)

    def to_control(self) -> ControlSystems:
        """The tuned loop as python-control systems with named signals (see
        :class:`~feedtune.loops.export.ControlSystems`).

        Works for any result with tuned values, an unstable or infeasible one included
        (python-control will show why).

        Returns
        -------
        ControlSystems
            ``closed_loop`` (``reference`` → ``position``), ``open_loop`` (``error`` →
            ``position``), ``error`` (``reference`` → ``error``) and, where the drive has a
            load path, ``load`` (``load_torque`` → ``position``); positions in
            ``position_unit`` (m or rad). Discrete with ``dt`` = the sampling period [s]
            for an exact sampled loop.

        Raises
        ------
        ResultError
            The result has no tuned values, or its embedded spec is not valid.
        TypeError
            A loop with no linear export (Tian's pulse generator).

        Examples
        --------
        >>> import control
        >>> systems = feedtune.load_result("result.json").to_control()   # doctest: +SKIP
        >>> control.stability_margins(systems.open_loop)                   # doctest: +SKIP
        """
        loop = self.loop()
        return loop_to_control(loop, plant_for(self.spec.plant).position_unit)

    # -- for people --------------------------------------------------------------------------

    def summary(self) -> str:
        """The summary ``feedtune tune`` prints on stderr: status, tuned values, objective,
        uniqueness, metrics, constraints, stability and the solver, with units."""
        return "\n".join(summary_lines(self.data))

    def __str__(self) -> str:
        return self.summary()

    def __repr__(self) -> str:
        where = f", path={str(self.path)!r}" if self.path is not None else ""
        tuned = ", ".join(f"{name}={t.value:.6g} {t.unit}" for name, t in self.data.tuned.items())
        return (f"<feedtune.Result {self.name!r}: {self.status}"
                f"{'' if self.success else ' (not successful)'}; {tuned or 'nothing tuned'}"
                f"{where}>")

    def _where(self) -> str:
        return str(self.path) if self.path is not None else f"result {self.name!r}"


def load_result(path: str | os.PathLike) -> Result:
    """Read a result JSON written by ``feedtune tune`` (or one of ``feedtune batch``'s).

    Parameters
    ----------
    path : str or path-like
        The result file.

    Returns
    -------
    Result
        The same object :func:`tune` returns; ``path`` set.

    Raises
    ------
    FileNotFoundError
        No file at ``path``.
    ResultError
        The file is not UTF-8 JSON, or not a feedtune result (a spec, a batch summary);
        the message names the file.

    Examples
    --------
    >>> result = feedtune.load_result("result.json")        # doctest: +SKIP
    >>> result.to_control().closed_loop                      # doctest: +SKIP
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
    return Result(result, path)


# -- the summary --------------------------------------------------------------------------

def _g(value: float | None) -> str:
    return "n/a" if value is None else f"{value:.6g}"


def summary_lines(result: TuneResult) -> list[str]:
    """Lines for people describing ``result`` (what ``feedtune tune`` prints on stderr)."""
    from feedtune.objectives import METRICS

    lines = [f"{result.name}: {result.status}"
             f"{'' if result.success else ' (not successful)'} — {result.message}"]
    lines.append("tuned:")
    width = max((len(n) for n in result.tuned), default=0)
    for name, tuned in result.tuned.items():
        notes = []
        if tuned.fixed:
            notes.append("fixed")
        if tuned.at_bound:
            bound = tuned.min if tuned.at_bound == "min" else tuned.max
            notes.append(f"at {tuned.at_bound} bound {_g(bound)}")
        note = f"  ({', '.join(notes)})" if notes else ""
        lines.append(f"  {name:<{width}}  {_g(tuned.value)} [{tuned.unit}]{note}")
    lines.append(f"objective: {_g(result.objective)}")
    lines += _optimum_lines(result.optimum)
    if result.metrics:
        lines.append("metrics:")
        width = max(len(k) for k in result.metrics)
        for key, metric in result.metrics.items():
            lines.append(f"  {key:<{width}}  {_g(metric.value)} [{metric.unit}]")
    stable = (result.stability or {}).get("stable")
    if result.constraints:
        lines.append("constraints:")
        for c in result.constraints:
            bounds = []
            if c.min is not None:
                bounds.append(f"min {_g(c.min)}")
            if c.max is not None:
                bounds.append(f"max {_g(c.max)}")
            metric = METRICS.get(c.metric)
            unit = f" [{metric.unit}]" if metric is not None else ""
            verdict = ("OK" if c.satisfied else
                       "NOT MET (loop unstable)" if c.value is None and not stable else "VIOLATED")
            lines.append(f"  {metric_label(c.metric, c.options)} = {_g(c.value)}{unit}"
                         f"  ({', '.join(bounds)})  {verdict}")
    lines += _robust_lines(result)
    stability = result.stability or {}
    text = "stable" if stable else ("UNSTABLE" if stable is not None else "unknown")
    if "spectral_radius" in stability:
        text += f", spectral radius {_g(stability['spectral_radius'])} [1] (z-plane poles)"
    elif "spectral_abscissa" in stability:
        text += f", spectral abscissa {_g(stability['spectral_abscissa'])} [1/s] (s-plane poles)"
    elif stability.get("certified_by") == "nyquist":  # measured data: no poles to list
        low, high = stability["band"]
        text += f" by the Nyquist count on the measured {_g(low)}–{_g(high)} [rad/s]"
    lines.append(f"stability: {text}")
    s = result.solver
    method = {"ipopt": "IPOPT", "brent": "Brent", "root": "root search"}.get(
        s.method, s.method.replace("_", " "))
    unit = {"differential_evolution": "generations", "convex": "linearisations",
            "root": "evaluations of e"}.get(s.method, "iterations")
    starts = "" if s.method == "convex" else f", {len(s.starts)} start(s)"  # one path, no starts
    lines.append(f"solver: {method} {s.return_status}, {s.iterations} {unit}{starts}; "
                 f"build {s.build_time:.3f} s, solve {s.solve_time:.3f} s")
    return lines


def _robust_lines(result: TuneResult) -> list[str]:
    """The summary's robust part: the scenarios held, and each constraint's worst case over
    the uncertain numbers with its margin (feedtune.robust)."""
    robust = result.robust
    if robust is None:
        return []
    origins = [s.origin for s in robust.scenarios]
    counts = ", ".join(f"{origins.count(o)} {o}" for o in dict.fromkeys(origins))
    lines = [f"robust ({robust.objective} objective): {len(robust.scenarios)} scenarios "
             f"({counts}), {robust.rounds} round(s), "
             f"{'converged' if robust.converged else 'NOT CONVERGED'}"]
    for case in robust.worst_cases:
        unit = next((f" [{m.unit}]" for m in result.metrics.values() if m.metric == case.metric),
                    "")
        at = ", ".join(f"{name} = {_g(value)}" for name, value in case.parameters.items())
        lines.append(f"  worst {metric_label(case.metric, case.options)} = {_g(case.value)}{unit}"
                     f" at {at}, margin {_g(case.margin)}  "
                     f"{'OK' if case.satisfied else 'VIOLATED'}")
    if robust.unstable_parameters:
        at = ", ".join(f"{n} = {_g(v)}" for n, v in robust.unstable_parameters.items())
        lines.append(f"  UNSTABLE at {at}")
    if robust.search:
        lines.append(f"  searched: {robust.search}")
    return lines


def _optimum_lines(optimum: OptimumCheck | None) -> list[str]:
    """The summary's word on uniqueness: said only when the optimum is not unique."""
    if optimum is None or optimum.unique is not False:
        return []
    lines = ["optimum: NOT UNIQUE"]
    if optimum.flat:
        lines.append(f"  the objective is flat along a direction of {', '.join(optimum.flat)} "
                     "(reduced Hessian at the optimum)")
    if optimum.spread:
        starts = ", ".join(str(i) for i in optimum.starts)
        lines.append(f"  starts {starts} reach the same objective at different tunables:")
    for name, spread in optimum.spread.items():
        lines.append(f"    {name}  {_g(spread.min)} … {_g(spread.max)} [{spread.unit}]")
    lines.append(f"  to pick one: {optimum.advice}")
    return lines
