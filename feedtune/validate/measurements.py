"""The validator's measurements declared as tables: metric name → how a model re-measures it.

Each validator model declares, once, the metrics it measures in a table
(``{"m_peak": Measurement(...), ...}``) and returns the tables that apply to its own
configuration from ``measurement_tables()`` (a sampled loop has frequency measures a
continuous one has not; Sato's circle metrics need an interpolator). ``measure`` runs
:func:`measure_entries` over them, so the metrics a model checks are data that
tests/contract/test_validator_contract.py compares with the metrics every loop reports:
a new metric without a measurement fails there instead of going unchecked.

The pole measures every model with poles shares (``decay_rate``, ``pole_damping``) are
:data:`feedtune.validate.poles.POLE_MEASUREMENTS`; :func:`declared` is the union.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

from feedtune.schema.model import read_number
from feedtune.validate.model import NotCovered
from feedtune.validate.tolerances import Context, judge


def _always(model, options: dict) -> bool:
    return True


@dataclass(frozen=True)
class Measurement:
    """How a model re-measures one metric.

    ``measure(model, options, reported, cache)`` → the value in the metric's unit, or
    (value, (scale, label)) when the model computes the physical scale itself
    (``min_radius``, whose scale depends on the ``reported`` value);
    ``cache`` is a dict shared by the measurements of one result (a step simulation run
    once for IAE, ISE and ITAE). It raises :class:`NotCovered` when this result's value
    cannot be compared (no crossover below Nyquist): that entry is left out.
    ``covers(model, options)``: whether the measurement applies to these options on this
    model (IAE after a step, not after a ramp); False leaves the metric unchecked, which
    the contract test reports.
    """

    measure: Callable[[object, dict, float, dict], object]
    covers: Callable[[object, dict], bool] = _always


#: a model's table: metric name → its measurement
Table = Mapping[str, Measurement]


@dataclass(frozen=True)
class Phase:
    """One pass over a result's metrics with one table. A reported ±∞ (a gain margin
    without a phase crossover, a run that never settles) is judged like any value:
    :func:`feedtune.validate.tolerances.judge` finds it ok only where the model's value is
    the same infinity."""

    table: Table


def measures(phases: Sequence[Phase], name: str, options: dict, model) -> bool:
    """Whether ``phases`` hold a measurement of metric ``name`` covering ``options``."""
    return any(name in p.table and p.table[name].covers(model, options) for p in phases)


def measure_entries(model, phases: Sequence[Phase], result: dict,
                    context: Context | Callable[[], Context]) -> list[dict]:
    """Entries for the metrics of ``result`` measured by ``phases``, phase by phase in the
    result's order, judged by :func:`feedtune.validate.tolerances.judge` on ``context``
    (or the context a callable gives, asked for only when there is an entry)."""
    entries: list[dict] = []
    cache: dict = {}
    metrics = list((result.get("metrics") or {}).values())
    for phase in phases:
        for m in metrics:
            # a result's JSON carries ±∞ as "Infinity" / "-Infinity" (a gain margin without
            # a phase crossover), read back as the float
            name, options = m["metric"], m.get("options") or {}
            reported = read_number(m.get("value"))
            if reported is None:
                continue
            row = phase.table.get(name)
            if row is None or not row.covers(model, options):
                continue
            try:
                value = row.measure(model, options, reported, cache)
            except NotCovered:
                continue
            scale = None
            if isinstance(value, tuple):
                value, scale = value
            if callable(context):
                context = context()
            entries.append(judge({**m, "value": reported}, value, context, scale))
    return entries
