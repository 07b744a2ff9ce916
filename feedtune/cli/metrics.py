"""``feedtune metrics``: the registered metrics and the plant configurations that support
each, computed by asking each metric on each configuration's loop."""

from __future__ import annotations

import contextlib
import json
import typing

import click

from feedtune.cli.common import emit
from feedtune.cli.describe import describe_fields, field_lines, unit_text
from feedtune.cli.examples import bundled_examples


def _plant_configurations() -> dict[str, list]:
    """Plant configuration (:func:`feedtune.schema.spec.plant_configuration`) → plant objects to
    probe: the plant of every bundled example and of every registered plant's defaults,
    each also with every other value of each of its choice fields (``technique``,
    ``model``, ...), those that validate."""
    from pydantic import ValidationError

    from feedtune.plants import PLANTS, plant_for
    from feedtune.schema.spec import plant_configuration

    bases = [{"type": name} for name in PLANTS]
    for path in bundled_examples().values():
        with contextlib.suppress(OSError, ValueError):
            plant = json.loads(path.read_text(encoding="utf-8")).get("plant")
            if isinstance(plant, dict) and plant.get("type") in PLANTS:
                bases.append(plant)
    found: dict[str, list] = {}
    for base in bases:
        params_model = PLANTS[base["type"]].Params
        variants = [base] + [{**base, field: choice}
                             for field, info in params_model.model_fields.items()
                             if field != "type" and typing.get_origin(info.annotation) is typing.Literal
                             for choice in typing.get_args(info.annotation)
                             if choice != base.get(field)]
        for variant in variants:
            try:
                params = params_model.model_validate(variant)
            except ValidationError:
                continue
            found.setdefault(plant_configuration(params), []).append(plant_for(params))
    return dict(sorted(found.items()))


def metric_support() -> dict[str, dict[str, list[str]]]:
    """Metric → ``supported`` (the plant configurations on whose loop it is defined) and
    ``reported_only`` (those of them where it cannot be an objective or a constraint);
    measured frequency responses, which have no loop, by the convex technique's table
    (:data:`feedtune.measured.datadriven_spec.ROLES`).

    Computed, not written down: each registered metric's ``supports`` and ``optimisable``
    asked on the loop of each configuration of :func:`_plant_configurations` (default
    tunable bounds, at their upper ends, as a spec's check builds it), with the metric's
    default options (none for options without defaults). A configuration counts when any
    of its probed plants supports the metric (a metric may also need a parameter, such as
    ``blu``, or a loop order).
    """
    from feedtune.objectives import METRICS
    from feedtune.schema.spec import _default_options, tunable_box

    support = {name: {"supported": [], "reported_only": []} for name in METRICS}
    for label, plants in _plant_configurations().items():
        loops = []
        for plant in plants:
            box = tunable_box(None, plant.tunables())[0]
            loops.append(plant.loop({n: hi for n, (lo, hi) in box.items()}, box))
        for name, cls in METRICS.items():
            metric = cls()
            options = _default_options(metric)
            supported = [loop for loop in loops if metric.supports(loop, options)]
            if supported:
                support[name]["supported"].append(label)
                if not any(metric.optimisable(loop, options) for loop in supported):
                    support[name]["reported_only"].append(label)
    from feedtune.measured.datadriven_spec import ROLES, TECHNIQUE  # measured data: no Loop

    for name, role in ROLES.items():
        support.setdefault(name, {"supported": [], "reported_only": []})
        support[name]["supported"].append(TECHNIQUE)
        if role == "reported":
            support[name]["reported_only"].append(TECHNIQUE)
    return support


def describe_metrics() -> dict[str, dict]:
    """Every registered metric: unit, description, reference, options, and the plant
    configurations that support it (:func:`metric_support`); then the metrics only measured
    frequency responses have (:data:`feedtune.measured.datadriven_spec.DATA_METRICS`, their
    options in the spec's ``sensitivity_weight``)."""
    from feedtune.measured.datadriven_spec import DATA_METRICS, SensitivityWeightSpec
    from feedtune.objectives import METRICS

    support = metric_support()
    described = {
        name: {"unit": m.unit, "description": m.description, "reference": m.reference,
               "options": describe_fields(m.Options), **support[name]}
        for name, m in METRICS.items()}
    for name, m in DATA_METRICS.items():
        described[name] = {**m, "options": describe_fields(SensitivityWeightSpec),
                           "options_at": "sensitivity_weight", **support[name]}
    return described


@click.command()
@click.option("--json", "as_json", is_flag=True, help="Print JSON instead of text.")
def metrics(as_json: bool) -> None:
    """List the metrics usable as objective terms or constraints, with units, references,
    options, and the plants and techniques that support each (asked of each metric on each
    plant configuration's loop: ``supported``, and ``reported_only`` where it cannot be an
    objective term or a constraint)."""
    described = describe_metrics()
    if as_json:
        emit((json.dumps(described, indent=2, ensure_ascii=False) + "\n").encode("utf-8"), None)
        return
    from feedtune.measured.datadriven_spec import TECHNIQUE

    configurations = [*_plant_configurations(), TECHNIQUE]
    lines = []
    for name, m in described.items():
        lines.append(f"{name} {unit_text(m['unit'])}: {m['description']}")
        if m["reference"]:
            lines.append(f"  reference: {m['reference']}")
        if m["options"]:
            lines.append(f"  options ({m['options_at']}):" if "options_at" in m else "  options:")
            lines.extend(field_lines(m["options"], "    "))
        lines.append("  supported by: " + _support_text(m["supported"], m["reported_only"],
                                                       configurations))
        lines.append("")
    click.echo("\n".join(lines).rstrip("\n"))


def _support_text(supported: list[str], reported_only: list[str], configurations: list[str]) -> str:
    """``supported`` for people: a plant type alone when every configuration of it is
    supported alike (all optimisable, or all reported only), else its configurations;
    "(reported only)" after those where the metric cannot be optimised."""
    parts = []
    for plant in dict.fromkeys(label.split("(")[0] for label in configurations):
        mine = [c for c in configurations if c.split("(")[0] == plant]
        held = [c for c in mine if c in supported]
        if not held:
            continue
        flags = {c in reported_only for c in held}
        if len(held) == len(mine) and len(flags) == 1:
            parts.append(plant + (" (reported only)" if flags == {True} else ""))
        else:
            parts += [c + (" (reported only)" if c in reported_only else "") for c in held]
    return ", ".join(parts) or "none"
