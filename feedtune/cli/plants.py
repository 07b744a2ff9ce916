"""``feedtune plants``: the registered plants, their parameters and tunables."""

from __future__ import annotations

import itertools
import json
import sys

import click

from feedtune.cli.common import emit, fmt
from feedtune.cli.describe import describe_fields, field_lines, literal_choices, unit_text


def _first_line(text: str | None) -> str:
    return (text or "").strip().splitlines()[0] if (text or "").strip() else ""


def _techniques(params_model) -> list | None:
    info = params_model.model_fields.get("technique")
    return literal_choices(info.annotation) if info is not None else None


def _plant_tunables(name: str, plant_cls) -> dict[str, dict]:
    """Tunables of ``plant_cls`` per technique ("*" when the plant has no techniques).

    Each lists every tunable some choice of the plant's other Literal fields (e.g. a
    compensator kind) brings in, so ``velocity_compensator.tau1`` is listed although the
    default (no compensator) has none.
    """
    params_model = plant_cls.Params
    techniques = _techniques(params_model)
    choices = {field: literal_choices(info.annotation)
               for field, info in params_model.model_fields.items()
               if field not in ("type", "technique") and literal_choices(info.annotation)}
    out = {}
    for technique in techniques or [None]:
        found = []
        for combination in itertools.product(*choices.values()):
            values = {"type": name, **dict(zip(choices, combination))}
            if technique is not None:
                values["technique"] = technique
            # only the fields that select the structure matter to tunables(): no validation
            found.append(plant_cls(params_model.model_construct(**values)).tunables())
        tunables = {}
        for listed in sorted(found, key=len, reverse=True):  # the plant's order, fullest first
            for tname, t in listed.items():
                tunables.setdefault(tname, {"unit": t.unit, "description": t.description,
                                            "min": t.min, "max": t.max})
        out[technique or "*"] = tunables
    return out


def _plant_classes() -> dict[str, type]:
    """Every registered plant class by its type name, the data plants' modules imported."""
    import importlib

    from feedtune.plants import DATA_PLANTS, PLANTS

    data_plants = {name: importlib.import_module(module).__dict__[
        "".join(part.capitalize() for part in name.split("_"))]
        for name, module in DATA_PLANTS.items()}
    return {**PLANTS, **data_plants}


def plant_parameters(name: str | None) -> list[dict] | None:
    """The parameters of plant type ``name`` as :func:`describe_plants` lists them (name,
    unit, description, …), or None for an unknown type: what a report's page shows,
    without the tunables of every plant's every structure (≈ 50 ms a report warm)."""
    plant_cls = _plant_classes().get(name)
    return None if plant_cls is None else describe_fields(plant_cls.Params)


def describe_plants() -> dict[str, dict]:
    """Every registered plant: parameters and, per technique, tunables with default bounds."""
    plants = {}
    for name, plant_cls in _plant_classes().items():
        module = sys.modules.get(plant_cls.__module__)
        plants[name] = {
            "summary": _first_line(getattr(module, "__doc__", None)),
            "reference": _first_line(plant_cls.Params.__doc__),
            "parameters": describe_fields(plant_cls.Params),
            "tunables": _plant_tunables(name, plant_cls),
        }
    return plants


@click.command()
@click.option("--json", "as_json", is_flag=True, help="Print JSON instead of text.")
def plants(as_json: bool) -> None:
    """List the plants: parameters (unit, default) and tunables with units and default
    bounds for each technique."""
    described = describe_plants()
    if as_json:
        emit((json.dumps(described, indent=2, ensure_ascii=False) + "\n").encode("utf-8"), None)
        return
    lines = []
    for name, plant in described.items():
        lines.append(f"{name}: {plant['summary']}")
        if plant["reference"]:
            lines.append(f"  {plant['reference']}")
        lines.append("  parameters (plant.*):")
        lines.extend(field_lines(plant["parameters"], "    "))
        for technique, tunables in plant["tunables"].items():
            heading = "tunables" if technique == "*" else f"tunables with technique {technique}"
            lines.append(f"  {heading} (default bounds):")
            width = max((len(t) for t in tunables), default=0)
            for tname, t in tunables.items():
                lines.append(f"    {tname:<{width}}  {fmt(t['min'])} … {fmt(t['max'])} "
                             f"{unit_text(t['unit'])}  {t['description']}")
        lines.append("")
    click.echo("\n".join(lines).rstrip("\n"))
