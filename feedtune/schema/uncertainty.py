"""Uncertain plant parameters in a spec: a set of values or a range, for robust tuning.

A plant parameter that enters the loop only through arithmetic (the plant's
:meth:`~feedtune.plants.base.Plant.numbers`: a field, or a coefficient inside one named by
its dotted path, ``model.denominator.1``) may be given, in ``plant``, as

* a number (today's form): known exactly;
* a list of numbers ``[v₁, v₂, …]``: each is a possible value, the first the nominal one;
* a range ``{"min": a, "max": b}``, optionally with ``"nominal"`` (default (a + b)/2);
* a tolerance ``{"nominal": n, "tolerance_percent": p}``: the range n·(1 ± p/100).

Inside a field that is not a number (a model's coefficient lists) only the two object
forms are read, since a list there is data (a root [re, im], a matrix row).

The canonical spec (what a result holds and ``feedtune schema`` describes) keeps the
nominal value in ``plant`` and the uncertainty in ``robust.parameters``, as ``{"values":
[...]}`` or ``{"min": a, "max": b}``; a spec may also be written that way.
:func:`move_inline_forms` turns the first spelling into the second before validation, and
remembers which parameters it moved so that an error names the place the user wrote
(``/plant/inertia/min``). feedtune.robust tunes such a spec.
"""

from __future__ import annotations

import copy
import itertools
import math
import types
import typing
from typing import Any, Literal

from pydantic import Field, PositiveInt, model_validator

from feedtune.schema.model import SpecModel

#: keys of the inline object forms; an object in a number field with other keys is left
#: to the plant's own validation (which refuses it)
FORM_KEYS = frozenset({"min", "max", "nominal", "tolerance_percent", "values"})
#: at most this many values in one parameter's set [count]
MAX_VALUES = 16
#: at most this many scenarios before refinement: corners × sets + interior samples [count];
#: each is one more closed loop in the NLP (Bhatia's cascade: ≈ 0.3 s of build each)
MAX_SCENARIOS = 32
#: worst-case refinement rounds at most [count]; each solves the NLP again
MAX_ROUNDS_LIMIT = 20


class UncertainParameter(SpecModel):
    """The values a plant parameter may take, in the parameter's own unit: a set
    (``values``) or a range (``min``/``max``); the nominal value is the plant's."""

    values: list[float] | None = Field(
        None, min_length=1, max_length=MAX_VALUES,
        description=f"Every value the parameter may take [its unit; at most {MAX_VALUES}]")
    min: float | None = Field(None, description="Smallest value of the range [its unit]")
    max: float | None = Field(None, description="Largest value of the range [its unit]")

    @model_validator(mode="after")
    def _one_form(self):
        if self.values is not None and (self.min is not None or self.max is not None):
            raise ValueError("give either 'values' or 'min'/'max', not both")
        if self.values is None and (self.min is None or self.max is None):
            raise ValueError("a range needs both 'min' and 'max' (or give 'values')")
        if self.min is not None and self.max is not None and not self.min < self.max:
            raise ValueError(f"min ({self.min}) must be less than max ({self.max}); a single "
                             "value is a plain number")
        return self

    def is_range(self) -> bool:
        return self.values is None

    def contains(self, value: float) -> bool:
        """Whether ``value`` [its unit] is one the parameter may take."""
        if self.values is not None:
            return value in self.values
        return self.min <= value <= self.max


class RobustSpec(SpecModel):
    """Robust tuning: the constraints hold for every value of the uncertain plant
    parameters (every combination of sets, every point of ranges)."""

    parameters: dict[str, UncertainParameter] = Field(
        default_factory=dict,
        description="Uncertain plant parameters by name (or write them in 'plant' as a "
                    "list [nominal, ...], {\"min\", \"max\"[, \"nominal\"]} or {\"nominal\", "
                    "\"tolerance_percent\"}) [each parameter's unit]")
    objective: Literal["nominal", "worst_case"] = Field(
        "nominal", description="nominal: the objective of the nominal plant; worst_case: the "
                               "largest objective over the scenarios the NLP holds")
    interior_samples: int = Field(
        2, ge=0, le=16,
        description="Latin-hypercube samples inside the ranges' box, besides its corners and "
                    "the nominal point, in the first solve [count]")
    max_rounds: PositiveInt = Field(
        8, le=MAX_ROUNDS_LIMIT,
        description="Worst-case refinement rounds at most: each searches the ranges for the "
                    "values that violate a constraint most, adds them and solves again "
                    f"[count, at most {MAX_ROUNDS_LIMIT}]")


def _is_number_field(annotation) -> bool:
    """Whether a pydantic field annotation is a (possibly optional, constrained) float."""
    if annotation is float:
        return True
    origin = typing.get_origin(annotation)
    if origin is typing.Annotated:
        return _is_number_field(typing.get_args(annotation)[0])
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(annotation) if a is not type(None)]
        return len(args) == 1 and _is_number_field(args[0])
    return False


def _finite_number(value: Any) -> bool:
    return (isinstance(value, (int, float)) and not isinstance(value, bool)
            and math.isfinite(value))


def inline_form(value: Any) -> bool:
    """Whether ``value``, in a number field of the plant, is an uncertain form."""
    return isinstance(value, list) or (isinstance(value, dict) and bool(value)
                                       and set(value) <= FORM_KEYS)


def split_form(value: Any) -> tuple[float, Any, tuple[str, str] | None]:
    """(nominal, canonical ``robust.parameters`` entry, problem) of an inline form.

    ``problem`` is (the field inside the form, message) when the form has no nominal value
    or no range (a tolerance that is not a percentage, ``tolerance_percent`` beside
    ``min``/``max``); the nominal and entry are then placeholders that validate, so the
    problem is the only error reported for it. A list or a min/max form is returned as it
    is: :class:`UncertainParameter` says what is wrong with it.
    """
    if isinstance(value, list):
        nominal = value[0] if value and _finite_number(value[0]) else PLACEHOLDER
        return nominal, {"values": value}, None
    form = dict(value)
    nominal = form.pop("nominal", None)
    tolerance = form.pop("tolerance_percent", None)
    placeholder = (PLACEHOLDER, {"min": PLACEHOLDER / 2, "max": PLACEHOLDER * 2})
    if "values" in form:
        return *placeholder, ("values", "a set of values is written as a list in 'plant', "
                                        "[nominal, other, ...]")
    if nominal is not None and not _finite_number(nominal):
        return *placeholder, ("nominal", "should be a number")
    if tolerance is not None or (nominal is not None and not form):
        if form:
            return *placeholder, ("tolerance_percent", "give 'min'/'max' or "
                                                       "'tolerance_percent', not both")
        if nominal is None:
            return *placeholder, ("nominal", "a tolerance needs the nominal value")
        if not _finite_number(tolerance) or not 0 < tolerance < 100:
            return *placeholder, ("tolerance_percent", "should be a number of percent "
                                                       "greater than 0 and less than 100")
        spread = abs(nominal) * tolerance / 100
        return nominal, {"min": nominal - spread, "max": nominal + spread}, None
    if nominal is None:
        low, high = form.get("min"), form.get("max")
        nominal = (low + high) / 2 if _finite_number(low) and _finite_number(high) else PLACEHOLDER
    return nominal, form, None


#: a number every plant number field accepts, put in a malformed form's place so that the
#: spec's only errors are the form's own
PLACEHOLDER = 1.0


def move_inline_forms(raw: Any, plant_models: dict) -> tuple[Any, set[str], list]:
    """``raw`` (a spec as parsed JSON) with every inline uncertain form in ``plant`` moved
    to ``robust.parameters``, its nominal value left in ``plant``; the names moved; and
    the problems found, as (location tuple, message).

    ``plant_models``: plant type → its Params model (an inline form is read only in a
    field that is a number). Lists and min/max forms are not validated here: they move as
    they are, and their errors name ``/plant/<name>/...`` (:func:`plant_pointer`).
    """
    if not isinstance(raw, dict) or not isinstance(raw.get("plant"), dict):
        return raw, set(), []
    plant = dict(raw["plant"])
    model = plant_models.get(plant.get("type")) if isinstance(plant.get("type"), str) else None
    if model is None:
        return raw, set(), []
    moved: dict[str, Any] = {}
    problems = []
    for name, value in raw["plant"].items():
        info = model.model_fields.get(name)
        if info is None:
            continue
        if not _is_number_field(info.annotation):
            if isinstance(value, (dict, list)):  # a model's coefficients, a table's entries
                plant[name] = _move_nested(value, (name,), moved, problems)
            continue
        if not inline_form(value):
            continue
        plant[name], moved[name], problem = split_form(value)
        if problem is not None:
            problems.append((("plant", name, problem[0]), problem[1]))
    if not moved:
        return raw, set(), []
    robust = raw.get("robust")
    if robust is None:
        robust = {}
    if isinstance(robust, dict):
        given = robust.get("parameters")
        parameters = dict(given) if isinstance(given, dict) else {}
        problems += [(("plant", name), "given twice: here and in /robust/parameters")
                     for name in moved if name in parameters]
        robust = dict(robust, parameters={**parameters, **moved})
    return dict(raw, plant=plant, robust=robust), set(moved), problems


def _move_nested(value: Any, path: tuple, moved: dict, problems: list) -> Any:
    """``value`` (a plant field that is not a number: a model, a list of coefficients) with
    every object form inside it (``{"min", "max"}``, ``{"nominal", "tolerance_percent"}``)
    replaced by its nominal value and recorded in ``moved`` under its dotted path
    (``model.denominator.1``, :func:`number_path`). A list inside it is data (a root
    [re, im], a matrix row), never a set of values: a set is written in
    ``robust.parameters``."""
    if isinstance(value, dict) and inline_form(value) and "values" not in value:
        nominal, entry, problem = split_form(value)
        name = ".".join(map(str, path))
        moved[name] = entry
        if problem is not None:
            problems.append((("plant", *path, problem[0]), problem[1]))
        return nominal
    if isinstance(value, dict):
        return {k: _move_nested(v, (*path, k), moved, problems) for k, v in value.items()}
    if isinstance(value, list):
        return [_move_nested(v, (*path, i), moved, problems) for i, v in enumerate(value)]
    return value


def number_path(name: str) -> tuple:
    """The place of an uncertain number in ``plant``: a field's name, or a dotted path into
    a field (``model.denominator.1``: the second coefficient of the model's denominator),
    list indices as ints."""
    return tuple(int(part) if part.isdigit() else part for part in name.split("."))


def with_numbers(plant: dict, numbers: dict[str, float]) -> dict:
    """A copy of ``plant`` (a plant spec as JSON) with each of ``numbers`` (name or dotted
    path, :func:`number_path` → value) in its place; a path that does not exist in
    ``plant`` raises KeyError or IndexError."""
    out = copy.deepcopy(plant)
    for name, value in numbers.items():
        *head, last = number_path(name)
        container = out
        for part in head:
            container = container[part]
        if isinstance(container, list) and not 0 <= last < len(container):
            raise IndexError(f"{name}: no such entry")
        container[last] = value
    return out


def plant_pointer(loc: tuple, moved: set[str]) -> tuple:
    """An error location in the canonical spec as the user wrote it: ``robust.parameters.
    <name>...`` of a parameter moved from ``plant`` is ``plant.<name>...`` (a dotted name
    its path)."""
    if len(loc) >= 3 and loc[:2] == ("robust", "parameters") and loc[2] in moved:
        return ("plant", *number_path(loc[2]), *loc[3:])
    return loc


def corner_count(parameters: dict[str, UncertainParameter]) -> int:
    """Combinations of every set's values and every range's two ends [count]."""
    return math.prod(len(p.values) if p.values is not None else 2 for p in parameters.values())


def corners(parameters: dict[str, UncertainParameter]) -> list[dict[str, float]]:
    """Every combination of every set's values and every range's ends, by name (as many
    as :func:`corner_count`: call it first, a product grows fast)."""
    names = list(parameters)
    choices = [p.values if p.values is not None else [p.min, p.max] for p in parameters.values()]
    return [dict(zip(names, combination)) for combination in itertools.product(*choices)]


def scenario_count(robust: RobustSpec) -> int:
    """Scenarios of the first solve: the nominal plant, every corner (:func:`corners`) and,
    when a parameter is a range, ``interior_samples`` points inside the ranges [count]."""
    ranges = any(p.is_range() for p in robust.parameters.values())
    return 1 + corner_count(robust.parameters) + (robust.interior_samples if ranges else 0)
