"""``feedtune schema``: the JSON Schema of a spec."""

from __future__ import annotations

import json

import click

from feedtune.cli.common import emit


def spec_schema() -> dict:
    """The JSON Schema of every spec ``feedtune tune`` takes: a model-based spec (the NLP's
    plants) or a data-driven one (plant ``frequency_response_data``, the convex technique),
    exactly one of the two (``oneOf``; their plant types differ). ``properties`` lists every
    top-level field of either, each with both forms where they differ (``anyOf``), so the
    fields and their units read at the top as before."""
    from feedtune.measured.datadriven_spec import DataDrivenSpec
    from feedtune.schema.spec import spec_json_schema

    model, data = spec_json_schema(), DataDrivenSpec.model_json_schema()
    defs = {**model.pop("$defs", {})}
    for name, definition in data.pop("$defs", {}).items():
        if defs.setdefault(name, definition) != definition:  # never two meanings of one name
            raise RuntimeError(f"the two specs' schemas define {name!r} differently")
    defs.update(ModelSpec=model, DataDrivenSpec=data)
    properties = {}
    for name in dict.fromkeys([*model["properties"], *data["properties"]]):
        forms = [s["properties"][name] for s in (model, data) if name in s["properties"]]
        properties[name] = forms[0] if len(forms) == 1 or forms[0] == forms[1] else {
            "anyOf": forms, "description": "model-based spec (first) or data-driven spec "
                                           "(second, plant frequency_response_data)"}
    return {"title": "Spec", "type": "object",
            "description": "A tuning spec: model-based (ModelSpec) or on measured frequency "
                           "responses (DataDrivenSpec). Units are in the field descriptions.",
            "properties": properties, "oneOf": [{"$ref": "#/$defs/ModelSpec"},
                                                {"$ref": "#/$defs/DataDrivenSpec"}],
            "$defs": defs}


@click.command()
def schema() -> None:
    """Print the JSON Schema of a spec, model-based or data-driven (units are in the field
    descriptions)."""
    text = json.dumps(spec_schema(), indent=2, ensure_ascii=False) + "\n"
    emit(text.encode("utf-8"), None)
