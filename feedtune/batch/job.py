"""One spec of a batch, as a worker runs it: parse, skip if already solved, tune.

:func:`solve` is what every executor (local processes, Dask) calls, so their results are
the same bytes. It never raises: a spec that cannot be used, a solver failure or an
internal error each comes back as an :class:`Outcome` with its status and message.
"""

from __future__ import annotations

import time
import traceback
from dataclasses import dataclass, field

from feedtune.schema.status import ERROR, INVALID, RESUMED, TIMEOUT, WORKER_DIED  # noqa: F401


@dataclass
class Outcome:
    """What became of one spec.

    ``status``: a TuneResult status, or ``invalid`` (the spec cannot be used; ``errors``
    lists (JSON pointer, message)), or ``resumed`` (its result already exists for this
    spec and feedtune version; nothing was solved). ``result``: the result JSON to write.
    ``row``: the summary's fields taken from the result.
    """

    status: str
    message: str
    spec_sha256: str | None = None
    errors: list[tuple[str, str]] = field(default_factory=list)
    result: bytes | None = None
    row: dict = field(default_factory=dict)
    time: float = 0.0


def summary_fields(result) -> dict:
    """The summary row's view of a TuneResult: objective, tuned values, verdicts."""
    from feedtune.validate import warning_lines

    validation = result.validation or {}
    return {
        "status": result.status,
        "success": result.success,
        "constraints_satisfied": all(c.satisfied for c in result.constraints),
        "objective": result.objective,
        "tuned": {name: tuned.value for name, tuned in result.tuned.items()},
        "message": result.message,
        # None: not validated (a plant the validator does not cover, an older result)
        "validation_ok": validation.get("ok"),
        # each gap beyond tolerance, worded as `feedtune tune` warns of it
        "validation_failures": ([line.removeprefix("warning: ")
                                 for line in warning_lines(validation)]
                                if validation.get("ok") is False else []),
        # not failures: a non-unique optimum (False) and implausibilities, said alongside
        "optimum_unique": result.optimum.unique if result.optimum is not None else None,
        "notes": notes(result),
    }


def notes(result) -> list[str]:
    """What a CI should see of a result that is not a failure: a non-unique optimum (which
    tunables the objective does not decide) and each plausibility warning."""
    found = []
    optimum = result.optimum
    if optimum is not None and optimum.unique is False:
        undecided = ", ".join(dict.fromkeys([*optimum.flat, *optimum.spread]))
        found.append(f"optimum not unique: the objective does not decide {undecided}")
    return found + [f"implausible: {w}" for w in result.warnings]


def solve(data: bytes, existing_sha256: str | None = None) -> Outcome:
    """Tune the spec in ``data``; skip it when ``existing_sha256`` is its canonical hash."""
    from feedtune.api import Result
    from feedtune.problem import tune
    from feedtune.schema.spec import SpecError, parse_spec

    started = time.perf_counter()
    try:
        spec = parse_spec(data)
    except SpecError as exc:
        return Outcome(INVALID, _errors_text(exc.errors), errors=list(exc.errors),
                       time=time.perf_counter() - started)
    except Exception as exc:  # noqa: BLE001 — one spec never stops the batch
        return _internal(exc, started)
    sha = spec.sha256()
    if sha == existing_sha256:
        return Outcome(RESUMED, "result already present for this spec and feedtune version",
                       spec_sha256=sha, time=time.perf_counter() - started)
    try:
        result = tune(spec)
    except SpecError as exc:
        return Outcome(INVALID, _errors_text(exc.errors), spec_sha256=sha,
                       errors=list(exc.errors), time=time.perf_counter() - started)
    except Exception as exc:  # noqa: BLE001
        return _internal(exc, started, sha)
    data = Result(result).to_json().encode("utf-8")  # the bytes `feedtune tune` writes
    return Outcome(result.status, result.message, spec_sha256=sha, result=data,
                   row=summary_fields(result), time=time.perf_counter() - started)


#: a spec that exercises what a worker's first spec would load lazily: the tuner, IPOPT's
#: library, the multistart's Halton sequence, restoration (scipy.optimize),
#: the reports' shared CasADi Functions and the validator (Koren's sampled-data example,
#: two starts)
WARM_UP_SPEC = {
    "name": "warm-up",
    "plant": {"type": "software_servo", "technique": "sampled_data",
              "time_constant": 0.02, "blu": 5e-6, "max_velocity": 0.04},
    "tunables": {"position_gain": {"min": 1, "max": 200},
                 "sampling_period": {"value": 0.015625}},
    "objective": [{"metric": "radial_error", "radius": 0.008, "feed": 0.04, "weight": 1}],
    "constraints": [{"metric": "damping_ratio", "min": 0.5}],
    "solver": {"multistart": 2},
}
_warmed = False


def warm_up() -> None:
    """Load, once per process, what the first spec of a worker would otherwise load on its
    own clock (≈ 0.5 s of CPU), by tuning WARM_UP_SPEC.

    The local executor calls it before forking its workers, so they start with all of it
    loaded and pay for it once between them (issue 15). Its result is discarded; a failure
    here only means the workers load it themselves.
    """
    global _warmed
    if _warmed:
        return
    _warmed = True
    import json

    try:
        solve(json.dumps(WARM_UP_SPEC).encode())
    except Exception:  # noqa: BLE001 — solve never raises; a warm-up must not stop a batch
        pass


def _errors_text(errors: list[tuple[str, str]]) -> str:
    """The errors on one line (control characters in a spec's keys escaped): the batch
    prints it in its table, where a newline could forge a CI log line."""
    from feedtune.schema.spec import printable

    return printable("; ".join(f"{pointer}: {message}" if pointer else message
                               for pointer, message in errors))


def _internal(exc: BaseException, started: float, sha: str | None = None) -> Outcome:
    """An exception feedtune did not expect: status ``error`` with the traceback's last frame."""
    frame = traceback.extract_tb(exc.__traceback__)[-1:] if exc.__traceback__ else []
    where = f" (at {frame[0].filename}:{frame[0].lineno})" if frame else ""
    return Outcome(ERROR, f"internal error {type(exc).__name__}: {exc}{where}",
                   spec_sha256=sha, time=time.perf_counter() - started)
