"""Registry entries (a plant's parameters, a metric's options) described for people and as
JSON: each pydantic field's unit (the first ``[unit]`` of its description), default,
choices and limits."""

from __future__ import annotations

import json
import re
import typing
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # pydantic is imported by the commands that read specs, not by --help
    from pydantic.fields import FieldInfo


_UNIT = re.compile(r"\[([^\[\]]+)\]")


def _unit_of(description: str | None) -> str | None:
    """The first ``[unit]`` in a field description, if any."""
    match = _UNIT.search(description or "")
    return match.group(1) if match else None


def literal_choices(annotation: Any) -> list | None:
    if typing.get_origin(annotation) is typing.Literal:
        return list(typing.get_args(annotation))
    return None


def _limits(info: FieldInfo) -> list[str]:
    limits = []
    for item in info.metadata:
        for attr, symbol in (("gt", ">"), ("ge", ">="), ("lt", "<"), ("le", "<=")):
            value = getattr(item, attr, None)
            if value is not None:
                limits.append(f"{symbol} {value}")
    return limits


def _default(info: FieldInfo) -> tuple[bool, Any]:
    """(required, default as JSON-able value)."""
    from pydantic_core import PydanticUndefined, to_jsonable_python

    if info.is_required():
        return True, None
    if info.default_factory is not None:
        return False, to_jsonable_python(info.default_factory())
    if info.default is PydanticUndefined:
        return True, None
    return False, to_jsonable_python(info.default)


def describe_fields(model) -> list[dict]:
    fields = []
    for name, info in model.model_fields.items():
        required, default = _default(info)
        fields.append({
            "name": name,
            "description": info.description or "",
            "unit": _unit_of(info.description),
            "required": required,
            "default": default,
            "choices": literal_choices(info.annotation),
            "limits": _limits(info),
        })
    return fields


def field_lines(fields: list[dict], indent: str) -> list[str]:
    lines = []
    for f in fields:
        if f["required"]:
            default = "required"
        else:
            default = f"default {json.dumps(f['default'], ensure_ascii=False)}"
        extra = []
        if f["choices"] and len(f["choices"]) > 1:
            extra.append("one of " + ", ".join(map(str, f["choices"])))
        elif f["choices"]:
            extra.append(f"= {f['choices'][0]}")
        extra.extend(f["limits"])
        tail = f"; {'; '.join(extra)}" if extra else ""
        lines.append(f"{indent}{f['name']}  ({default}{tail})")
        if f["description"]:
            lines.append(f"{indent}    {f['description']}")
    return lines


def unit_text(unit: str) -> str:
    return f"[{unit}]"
