"""Base class of every spec and result model: frozen, strict about unknown keys and NaN;
and the one number type a result may hold infinite."""

import math
from typing import Annotated

from pydantic import (AfterValidator, AllowInfNan, BaseModel, ConfigDict, PlainSerializer,
                      WithJsonSchema)

#: how JSON carries ±∞ (it has no such number): the strings pydantic writes with
#: ``ser_json_inf_nan="strings"`` and JavaScript's ``Number()`` reads
JSON_INFINITY = {math.inf: "Infinity", -math.inf: "-Infinity"}


class SpecModel(BaseModel):
    """Frozen pydantic model that rejects unknown keys and NaN/Infinity."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)


def empty_list() -> list:
    """A new empty list: the ``default_factory`` of a spec's list fields. pydantic reads a
    default factory's signature when it builds a model, and the builtin ``list``'s (a text
    signature) costs the compilation of the standard tokenizer's regular expressions,
    ≈ 2.4 ms of ``feedtune validate``'s start-up (issue 15)."""
    return []


def json_number(value: float | None) -> float | str | None:
    """``value`` as JSON carries it: ±∞ as the string "Infinity" / "-Infinity", else itself."""
    return JSON_INFINITY.get(value, value) if value is not None else None


def read_number(value) -> float | None:
    """A result's number as read from its JSON (:func:`json_number` undone): "Infinity" /
    "-Infinity" as ±∞, a number as a float, anything else (null) as None."""
    if isinstance(value, str):
        return next((number for number, text in JSON_INFINITY.items() if text == value), None)
    number = isinstance(value, (int, float)) and not isinstance(value, bool)
    return float(value) if number else None


def _not_nan(value: float) -> float:
    if math.isnan(value):
        raise ValueError("NaN is not a value (null stands for an undefined one)")
    return value


#: A number that may be +∞ or −∞ but never NaN: a quantity that does not exist where its
#: infinity is meant (a gain margin without a phase crossover is +∞, as python-control's
#: ``stability_margins`` gives it). In Python a float (``math.inf``); in JSON a number, or
#: the string "Infinity" / "-Infinity" (:func:`json_number`), read back as the float.
ExtendedFloat = Annotated[
    float, AllowInfNan(True), AfterValidator(_not_nan),
    PlainSerializer(json_number, when_used="json"),
    WithJsonSchema({"anyOf": [{"type": "number"}, {"enum": list(JSON_INFINITY.values())}]})]
