"""The JSON spec: pydantic models built from the plant and metric registries.

A spec names a plant, which of its tunables are fixed or free (with bounds), the
objective (weighted metric terms) and constraints (metric bounds), and solver settings.
:func:`parse_spec` reads strict JSON and returns a :class:`Spec` or raises
:class:`SpecError` listing every bad field by JSON pointer.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import re
import sys
import threading
from typing import Annotated, Any, Callable, Literal, Union, get_origin

from pydantic import (Field, PositiveFloat, PositiveInt, TypeAdapter, ValidationError,
                      create_model, field_validator, model_serializer, model_validator)
from pydantic_core import SchemaValidator, core_schema

from feedtune.expr import Unbounded, to_float
from feedtune.loops.loop import HorizonError
from feedtune.loops.protocols import Capability
from feedtune.loops.errors import SampledModelError
from feedtune.lazy import Loaded
from feedtune.objectives import METRIC_PATHS, metric_class
from feedtune.plants import DATA_PLANTS, PLANT_PATHS, plant_for
from feedtune.schema.ipopt import IpoptOptions
from feedtune.schema.model import SpecModel, empty_list
from feedtune.schema.uncertainty import (MAX_SCENARIOS, RobustSpec, move_inline_forms,
                                         number_path, plant_pointer, scenario_count,
                                         with_numbers)

MAX_SPEC_BYTES = 1_000_000
MAX_JSON_DEPTH = 32
#: work limits: each term or constraint adds expressions (and exchange rows) to the NLP
MAX_OBJECTIVE_TERMS = 64
MAX_CONSTRAINTS = 64
#: characters a name may not hold: C0/C1 controls and DEL (a name is printed in CI logs)
_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f]")


class SpecError(ValueError):
    """A spec that cannot be used (``feedtune tune`` and ``validate``: exit status 2).

    Attributes
    ----------
    errors : list of (str, str)
        (JSON pointer, message) for every problem found, e.g.
        ``("/plant/time_constant", "should be greater than 0")``; the pointer is ``""``
        for the spec as a whole.
    """

    def __init__(self, errors: list[tuple[str, str]]):
        self.errors = errors
        super().__init__("; ".join(f"{p or '/'}: {m}" for p, m in errors))


class TunableSpec(SpecModel):
    """One tunable: fixed (``value``) or free within [min, max] (defaults: the plant's)."""

    value: PositiveFloat | None = Field(None, description="Fix the tunable at this value [its unit]")
    min: PositiveFloat | None = Field(None, description="Lower bound [its unit]")
    max: PositiveFloat | None = Field(None, description="Upper bound [its unit]")
    initial: PositiveFloat | None = Field(
        None, description="First multistart point [its unit]; default: geometric mid-bound")

    @model_validator(mode="after")
    def _consistent(self):
        if self.value is not None and (self.min is not None or self.max is not None
                                       or self.initial is not None):
            raise ValueError("give either 'value' or 'min'/'max'/'initial', not both")
        if self.min is not None and self.max is not None and self.min > self.max:
            raise ValueError(f"min ({self.min}) is greater than max ({self.max})")
        return self


#: IPOPT options that ``solver`` has fields for: the spec sets them there
_SOLVER_FIELDS = {"max_iter": "max_iter", "tol": "tol", "max_wall_time": "time_limit"}


def _unknown_ipopt_option(name: str) -> str:
    """Why ``name`` cannot be an IPOPT option of a spec, listing the ones that can."""
    allowed = ", ".join(sorted(IpoptOptions.__annotations__))
    if name in _SOLVER_FIELDS:
        return f"set it as /solver/{_SOLVER_FIELDS[name]} instead"
    return (f"{json.dumps(name)} is not an IPOPT option a spec may set (options that name "
            f"files or libraries, print, or that feedtune sets itself are refused); "
            f"allowed: {allowed}")


class SolverSpec(SpecModel):
    """IPOPT settings and multistart."""

    multistart: PositiveInt = Field(8, le=256, description="Number of deterministic starting points [count]")
    max_iter: PositiveInt = Field(500, description="IPOPT iteration limit per start [count]")
    tol: PositiveFloat = Field(1e-9, description="IPOPT convergence tolerance on the scaled problem [1]")
    time_limit: PositiveFloat = Field(
        60.0, description="Wall-clock limit of each IPOPT solve [s]; a start makes no further "
                          "exchange rounds once it has run this long")
    expand: bool | None = Field(
        None, description="Expand the NLP to CasADi SX before solving: faster solves, slower "
                          "build; null (default) expands when step responses are short, except an "
                          "NLP of frequency grids kept as whole rows")
    ipopt_options: IpoptOptions = Field(
        default_factory=dict, description="Algorithmic IPOPT options (an allow-list, with "
                                          "IPOPT's types and ranges; units per option)")


def _camel(name: str) -> str:
    return "".join(part.capitalize() for part in name.split("_"))


def _objective_model(name, metric):
    goal = (Literal["minimize", "maximize"], Field(
        "minimize", description="minimize: add weight·value to the objective; maximize: "
                                "subtract it (e.g. bandwidth)"))
    if metric.direction == "min":  # the tuner holds it from below only (Metric.direction)
        goal = (Literal["maximize"], Field(
            "maximize", description="maximize (the only goal: the tuner holds this metric "
                                    "from below only): subtract weight·value"))
    return create_model(
        f"{_camel(name)}Objective", __base__=metric.Options,
        metric=(Literal[name], Field(description=metric.description)),
        weight=(PositiveFloat, Field(1.0, description=f"Weight of this term [1/({metric.unit})]")),
        goal=goal,
    )


def _from_below_only(name):
    def check(cls, value):
        if value is not None:
            raise ValueError(f"{name} can only be bounded from below ('min'): an upper bound "
                             "would say that some closed-loop pole is slow or lightly damped, "
                             "which no smooth constraint expresses")
        return value

    return field_validator("max")(check)


def _constraint_model(name, metric):
    def _has_bound(self):
        if self.min is None and self.max is None:
            raise ValueError("a constraint needs 'min', 'max' or both")
        if self.min is not None and self.max is not None and self.min > self.max:
            raise ValueError(f"min ({self.min}) is greater than max ({self.max})")
        return self

    validators = {"_has_bound": model_validator(mode="after")(_has_bound)}
    if metric.direction == "min":
        validators["_from_below_only"] = _from_below_only(name)
    return create_model(
        f"{_camel(name)}Constraint", __base__=metric.Options,
        __validators__=validators,
        metric=(Literal[name], Field(description=metric.description)),
        min=(float | None, Field(None, description=f"Lower bound [{metric.unit}]")),
        max=(float | None, Field(None, description=f"Upper bound [{metric.unit}]")),
    )


def _tagged_union(models: tuple, tag: str):
    """Discriminated union of ``models`` on field ``tag`` (a single model stands alone)."""
    if len(models) == 1:
        return models[0]
    return Annotated[Union[models], Field(discriminator=tag)]


class LazyUnion:
    """The discriminated union, on field ``tag``, of one model per name of a registry, each
    model built (and its module imported) when a spec first names it.

    A spec names one plant and a few metrics of the registries' 5 and 44; building every
    model (and importing every plant's and metric's module) was most of ``feedtune
    validate``'s time (issue 15's start-up; benchmarks/README.md). An item whose tag names
    a model is validated by a one-member union of that model: the same validation, error
    locations and messages as the whole union's, which validates every other item (an
    unknown or missing tag: its error lists every tag) and gives the JSON Schema.

    Parameters
    ----------
    names : collection of str
        The tags, in the order of the union's members.
    tag : str
        The field that picks the model (``"type"``, ``"metric"``).
    build : callable
        Name → its model.
    """

    def __init__(self, names, tag: str, build: Callable[[str], type]):
        self._names, self._tag, self._build = names, tag, build
        self._models: dict[str, type] = {}
        self._lock = threading.Lock()  # one class per name, also when threads parse specs

    def model(self, name: str) -> type:
        """The model of ``name``'s items (one class per name and process)."""
        with self._lock:
            if name not in self._models:
                self._models[name] = self._build(name)
            return self._models[name]

    @functools.cached_property
    def union(self) -> TypeAdapter:
        """The discriminated union of every name's model."""
        return TypeAdapter(_tagged_union(tuple(self.model(name) for name in self._names),
                                         self._tag))

    @functools.cache
    def _one(self, name: str) -> SchemaValidator:
        return SchemaValidator(core_schema.tagged_union_schema(
            {name: self.model(name).__pydantic_core_schema__}, self._tag, from_attributes=True))

    def validate_python(self, value: Any, strict: bool | None = None):
        """``value`` (a dict or a model) as the model its tag names."""
        tag = (value.get(self._tag) if isinstance(value, dict)
               else getattr(value, self._tag, None))
        if isinstance(tag, str) and tag in self._names:
            return self._one(tag).validate_python(value, strict=strict)
        return self.union.validate_python(value, strict=strict)

    def __get_pydantic_core_schema__(self, source, handler) -> core_schema.CoreSchema:
        """Items validated by :meth:`validate_python` (strict when the spec's validation is),
        serialised as their own model."""
        def validate(value, handler):
            return self.validate_python(value, strict=_is_strict(handler))

        return core_schema.no_info_wrap_validator_function(
            validate, core_schema.int_schema(),
            serialization=core_schema.wrap_serializer_function_ser_schema(
                lambda value, serialize: serialize(value), schema=core_schema.any_schema()))

    def __get_pydantic_json_schema__(self, schema, handler):
        """The whole union's JSON Schema (``feedtune schema``)."""
        return handler(self.union.core_schema)


class MetricTerms(LazyUnion):
    """Objective terms or constraints: the :class:`LazyUnion`, on ``metric``, of one model
    per metric, ``build(name, metric class)``."""

    def __init__(self, build: Callable[[str, type], type]):
        super().__init__(METRIC_PATHS, "metric", lambda name: build(name, metric_class(name)))


def _is_strict(handler) -> bool:
    """Whether the validation that called a wrap validator runs in strict mode (pydantic
    tells a validator function its mode, not its strictness): ``handler`` validates an
    int, which a string is only in lax mode."""
    try:
        handler("0")
    except ValidationError:
        return True
    return False


#: plant type → its Params model (where an uncertain form may stand for a number)
PLANT_MODELS = Loaded(PLANT_PATHS, lambda plant: plant.Params)
#: a spec's ``plant``: the union of the plants' Params models, each built on first use
PLANT_SPECS = LazyUnion(PLANT_PATHS, "type", PLANT_MODELS.__getitem__)
PlantSpec = Annotated[Any, PLANT_SPECS]
#: the models of objective terms and of constraints, built per metric on first use
OBJECTIVE_TERMS, CONSTRAINTS = MetricTerms(_objective_model), MetricTerms(_constraint_model)
ObjectiveTerm = Annotated[Any, OBJECTIVE_TERMS]
ConstraintSpec = Annotated[Any, CONSTRAINTS]


class Spec(SpecModel):
    """A tuning problem: plant, tunables, objective, constraints, solver.

    The pydantic model of a spec file (``feedtune schema`` prints its JSON Schema, units in
    every description). Build one in code from the same structure, SI units throughout,
    and give it to :func:`feedtune.tune`, which checks it as ``feedtune validate`` checks a
    file; the model alone checks only types and ranges (frozen: change a copy with
    ``model_copy(update=...)``).

    Parameters
    ----------
    name : str
        Names the problem and its batch result file [text].
    plant : dict
        ``{"type": ...}`` and the plant's parameters (``feedtune plants``).
    tunables : dict, optional
        Per tunable ``{"value": ...}`` (fixed) or ``{"min": ..., "max": ...}`` [its unit].
    objective : list of dict
        ``{"metric": ..., "weight": ...}`` and the metric's options (``feedtune metrics``).
    constraints : list of dict, optional
        ``{"metric": ..., "min": ..., "max": ...}`` [the metric's unit].
    solver : dict, optional
        ``multistart`` [count], ``max_iter`` [count], ``tol`` [1], ``time_limit`` [s], ...

    Examples
    --------
    >>> spec = feedtune.Spec.model_validate({                      # doctest: +SKIP
    ...     "name": "servo",
    ...     "plant": {"type": "software_servo", "technique": "reference_pulse",
    ...               "time_constant": 0.02, "blu": 5e-6, "max_velocity": 0.04},
    ...     "objective": [{"metric": "iae"}]})
    >>> feedtune.tune(spec.model_copy(update={"name": "servo-2"}))   # doctest: +SKIP
    """

    name: str = Field(min_length=1, max_length=200,
                      description="Name of this tuning problem (also names its batch result "
                                  "file); printable characters only [text]")
    description: str = Field("", max_length=10_000, description="Free text for people")
    plant: PlantSpec
    tunables: dict[str, TunableSpec] = Field(
        default_factory=dict,
        description="Tunables by name (see `feedtune plants`); omitted ones are free within "
                    "the plant's default bounds")
    objective: list[ObjectiveTerm] = Field(
        min_length=1, max_length=MAX_OBJECTIVE_TERMS,
        description="Weighted sum of metric terms to minimise (terms with goal maximize count "
                    f"negatively) [at most {MAX_OBJECTIVE_TERMS} terms]")
    constraints: list[ConstraintSpec] = Field(
        default_factory=empty_list, max_length=MAX_CONSTRAINTS,
        description=f"Metric bounds that must hold [at most {MAX_CONSTRAINTS} constraints]")
    solver: SolverSpec = Field(default_factory=SolverSpec)
    robust: RobustSpec | None = Field(
        None, description="Robust tuning over uncertain plant parameters (given in 'plant' as "
                          "a list or a range, or here under 'parameters'); omitted: the plant "
                          "is known exactly")

    @model_validator(mode="before")
    @classmethod
    def _uncertain_plant_numbers(cls, data):
        """Plant numbers written as a list or a range move to ``robust.parameters``, their
        nominal value staying in ``plant`` (feedtune.schema.uncertainty)."""
        data, _, problems = move_inline_forms(data, PLANT_MODELS)
        if problems:
            raise ValueError("; ".join(f"/{'/'.join(map(str, loc))}: {message}"
                                       for loc, message in problems))
        return data

    @model_serializer(mode="wrap")
    def _without_absent_robust(self, handler):
        """A spec without uncertain parameters dumps as it did before robust tuning existed
        (its canonical JSON and hash unchanged)."""
        data = handler(self)
        if data.get("robust", 0) is None:
            del data["robust"]
        return data

    @field_validator("name")
    @classmethod
    def _printable(cls, name: str) -> str:
        bad = _CONTROL.search(name)
        if bad:
            raise ValueError(f"holds the control character {json.dumps(bad.group())} (a name is "
                             "printed in logs and names a file: printable characters only)")
        return name

    def canonical_json(self) -> str:
        """Sorted, compact JSON of the spec with every default filled in."""
        return json.dumps(self.model_dump(mode="json"), sort_keys=True, separators=(",", ":"))

    def sha256(self) -> str:
        return hashlib.sha256(self.canonical_json().encode()).hexdigest()


# -- strict JSON -------------------------------------------------------------------------

class _NonFinite:
    """Where the JSON text held NaN, Infinity or -Infinity (found after parsing, by pointer)."""

    def __init__(self, token: str):
        self.token = token


class _Object(dict):
    """A JSON object; ``duplicates`` lists the keys it held more than once (last one kept)."""

    duplicates: tuple = ()


def _object(pairs) -> _Object:
    value = _Object(pairs)
    if len(value) < len(pairs):
        seen, repeated = set(), []
        for key, _ in pairs:
            if key in seen and key not in repeated:
                repeated.append(key)
            seen.add(key)
        value.duplicates = tuple(repeated)
    return value


def _strictness_errors(value: Any, pointer: str = "") -> list[tuple[str, str]]:
    """(pointer, message) for every NaN/Infinity and duplicate key in a parsed document."""
    errors = []
    if isinstance(value, _NonFinite):
        errors.append((pointer, f"{value.token} is not valid JSON (use a finite number)"))
    elif isinstance(value, dict):
        for key in getattr(value, "duplicates", ()):
            errors.append((f"{pointer}/{_escape(key)}",
                           f"duplicate key {key!r} (JSON objects name each key once)"))
        for key, item in value.items():
            errors.extend(_strictness_errors(item, f"{pointer}/{_escape(key)}"))
    elif isinstance(value, list):
        for i, item in enumerate(value):
            errors.extend(_strictness_errors(item, f"{pointer}/{i}"))
    return errors


def _depth(value: Any, limit: int, level: int = 0) -> int:
    if level > limit:
        return level
    if isinstance(value, dict):
        return max((_depth(v, limit, level + 1) for v in value.values()), default=level + 1)
    if isinstance(value, list):
        return max((_depth(v, limit, level + 1) for v in value), default=level + 1)
    return level


def load_json(data: bytes | str) -> Any:
    """Parse strict JSON (no NaN/Infinity, no duplicate keys, UTF-8, size-limited).

    A UTF-8 byte-order mark at the start is skipped (editors on Windows write one).
    """
    if isinstance(data, bytes):
        if len(data) > MAX_SPEC_BYTES:
            raise SpecError([("", f"spec is {len(data)} bytes; the limit is {MAX_SPEC_BYTES}")])
        try:
            data = data.decode("utf-8-sig")
        except UnicodeDecodeError as exc:
            raise SpecError([("", f"spec is not UTF-8 text (byte {exc.start})")]) from None
    data = data.removeprefix("\ufeff")
    if len(data) > MAX_SPEC_BYTES:
        raise SpecError([("", f"spec is {len(data)} characters; the limit is {MAX_SPEC_BYTES}")])
    if not data.strip():
        raise SpecError([("", "spec is empty")])
    try:
        value = json.loads(data, parse_constant=_NonFinite, object_pairs_hook=_object)
    except json.JSONDecodeError as exc:
        raise SpecError([("", f"invalid JSON at line {exc.lineno} column {exc.colno}: "
                              f"{exc.msg.removesuffix(' at')}")]) from None
    except RecursionError:
        raise SpecError([("", f"JSON nested deeper than {MAX_JSON_DEPTH} levels")]) from None
    except ValueError as exc:  # e.g. an integer of more digits than Python converts
        raise SpecError([("", f"invalid JSON: {exc}")]) from None
    if _depth(value, MAX_JSON_DEPTH) > MAX_JSON_DEPTH:
        raise SpecError([("", f"JSON nested deeper than {MAX_JSON_DEPTH} levels")])
    errors = _strictness_errors(value)
    if errors:
        raise SpecError(errors)
    return value


def _escape(token) -> str:
    """One RFC 6901 reference token."""
    return str(token).replace("~", "~0").replace("/", "~1")


@functools.cache
def _union_tags() -> frozenset[str]:
    """Discriminator values pydantic puts into error locations (a lone model has no tag):
    the plant types, the metric names and the linear plant's model types (its module is
    imported here, on the way to an error message, if the spec did not name it)."""
    from feedtune.plants.linear import MODEL_TYPES

    return frozenset((set(PLANT_PATHS) if len(PLANT_PATHS) > 1 else set())
                     | (set(METRIC_PATHS) if len(METRIC_PATHS) > 1 else set())
                     | set(MODEL_TYPES))


def _pointer(loc: tuple, raw: Any) -> str:
    """JSON pointer of a pydantic error location.

    Walks the input alongside the location: union tags (the value of the node's own
    ``type``/``metric`` field) and union-member labels (``str``, ``int``, ...) are not
    fields and are skipped; a key missing from an object is kept (a required field).
    """
    parts = []
    node = raw
    tag_seen = False  # a tag comes once, first, at the node it selects a model for
    for item in loc:
        if isinstance(node, dict):
            tag = node.get("type", node.get("metric"))
            if not tag_seen and item == tag and item in _union_tags():
                tag_seen = True
                continue
            parts.append(_escape(item))
            node = node.get(item)
        elif isinstance(node, list) and isinstance(item, int) and 0 <= item < len(node):
            parts.append(_escape(item))
            node = node[item]
        else:
            continue  # a union-member or validator label inside a non-container value
        tag_seen = False
    return "/" + "/".join(parts) if parts else ""


def _errors_by_pointer(errors: list[tuple[str, str]]) -> list[tuple[str, str]]:
    """One entry per pointer: alternatives of a union become 'a or b'."""
    merged: dict[str, list[str]] = {}
    for pointer, message in errors:
        merged.setdefault(pointer, [])
        if message not in merged[pointer]:
            merged[pointer].append(message)
    return [(pointer, " or ".join(messages)) for pointer, messages in merged.items()]


# -- messages in JSON's vocabulary -------------------------------------------------------

def json_type(value: Any) -> str:
    """The JSON name of a parsed value's type: null, true/false, number, string, array, object."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return "a number"
    if isinstance(value, str):
        return "a string"
    if isinstance(value, list):
        return "an array"
    if isinstance(value, dict):
        return "an object"
    return "a value JSON has no type for"


#: pydantic error types that name a Python type (or none), said in JSON's words instead
_EXPECTED = {
    "dict_type": "a valid object", "model_type": "a valid object",
    "model_attributes_type": "a valid object", "list_type": "a valid array",
    "bool_type": "true or false", "int_type": "a valid integer", "float_type": "a valid number",
    "string_type": "a valid string",
}
_CONTAINERS = {"List": "Array", "Dictionary": "Object", "Tuple": "Array", "Set": "Array"}


def _message(error: dict) -> str:
    """A pydantic error's message in JSON's vocabulary (null, number, string, array, object,
    true/false), saying what was given: never a Python type name."""
    kind, ctx, given = error["type"], error.get("ctx") or {}, error.get("input")
    if kind == "extra_forbidden" and error["loc"][-2:-1] == ("ipopt_options",):
        return _unknown_ipopt_option(str(error["loc"][-1]))
    if kind in _EXPECTED:
        return f"Input should be {_EXPECTED[kind]}, not {json_type(given)}"
    if kind == "literal_error":
        return f"Input should be {ctx['expected']}, not {json.dumps(given)}"
    if kind in ("too_long", "too_short"):
        container = _CONTAINERS.get(ctx.get("field_type"), "Array")
        bound = "at most" if kind == "too_long" else "at least"
        limit = ctx.get("max_length", ctx.get("min_length"))
        return (f"{container} should have {bound} {limit} item{'s' if limit != 1 else ''}, "
                f"not {ctx.get('actual_length')}")
    if kind == "union_tag_invalid" and isinstance(given, dict):
        # the tag as JSON: pydantic prints Python's str() of it, a string in single quotes
        # ('None' would read as Python's None)
        value = given.get(ctx["discriminator"].strip("'"))
        return error["msg"].replace(f"tag '{ctx['tag']}'", f"tag {json.dumps(value)}", 1)
    return error["msg"].removeprefix("Value error, ")


def _schema_errors(exc: ValidationError, raw: Any,
                   moved: set[str] = frozenset()) -> list[tuple[str, str]]:
    """(pointer, message) for each error of the validation of ``raw``; alternatives of a
    union at one pointer become 'a or b'. ``moved``: the uncertain plant parameters that
    ``raw`` wrote in ``plant`` (their errors are named there, not in ``robust``)."""
    return _errors_by_pointer([(_pointer(plant_pointer(e["loc"], moved), raw), _message(e))
                               for e in exc.errors()])


def _merged(schema: list[tuple[str, str]], semantic: list[tuple[str, str]]) -> list[tuple[str, str]]:
    """Schema errors, then registry errors; two at one pointer are joined by '; '."""
    merged = dict(schema)
    for pointer, message in semantic:
        merged[pointer] = f"{merged[pointer]}; {message}" if pointer in merged else message
    return list(merged.items())


# -- checks that need the registries -----------------------------------------------------

_PLANT, _TUNABLE = PLANT_SPECS, TypeAdapter(TunableSpec)
_TERM = {"objective": OBJECTIVE_TERMS, "constraints": CONSTRAINTS}


def _valid(adapter: TypeAdapter | LazyUnion, value: Any):
    """``value`` validated (strict), or None when it does not validate."""
    try:
        return adapter.validate_python(value, strict=True)
    except ValidationError:
        return None


def tunable_box(raw_tunables: Any, tunables: dict) -> tuple[dict, list[tuple[str, str]], bool]:
    """((min, max) of every tunable, errors, whether every given tunable validated).

    The spec's bounds where given, the plant's default bounds for what it omits; a fixed
    tunable's box is its value. ``raw_tunables`` may be the parsed JSON or a Spec's
    ``tunables``: the registry checks and the tuner read the box from here alike.
    """
    given = raw_tunables if isinstance(raw_tunables, dict) else {}
    box, errors, complete = {}, [], isinstance(raw_tunables, dict) or raw_tunables is None
    for name, tunable in tunables.items():
        spec = _valid(_TUNABLE, given[name]) if name in given else TunableSpec()
        if spec is None:
            complete = False
            spec = TunableSpec()
        if spec.value is not None:
            box[name] = (spec.value, spec.value)
            continue
        lower = spec.min if spec.min is not None else tunable.min
        upper = spec.max if spec.max is not None else tunable.max
        if lower > upper:
            errors.append((f"/tunables/{_escape(name)}",
                           f"bounds [{lower}, {upper}] {tunable.unit} are empty (defaults "
                           f"[{tunable.min}, {tunable.max}] fill what the spec omits)"))
            complete = False
            upper = lower
        elif spec.initial is not None and not lower <= spec.initial <= upper:
            errors.append((f"/tunables/{_escape(name)}/initial",
                           f"{spec.initial} is outside [{lower}, {upper}]"))
        box[name] = (lower, upper)
    return box, errors, complete


def _tuner_horizon_samples(plant, box: dict, loop) -> int:
    """Samples the tuner's loop sums at step-response horizon scale 1 (HorizonError above
    the limit). With a tunable free the tuner builds it on symbols: ``loop`` (the same plant
    and box) answers from its numbers. With every tunable fixed, a loop of those numbers is
    built, as the tuner does."""
    if any(lower != upper for lower, upper in box.values()):
        return loop.symbolic_horizon_samples
    import casadi as ca  # the spectral radius of a loop of numbers

    return plant.loop({name: ca.MX(lower) for name, (lower, _) in box.items()},
                      box).horizon_samples


def _default_options(metric):
    """The metric's options with their defaults, or None when some have no default."""
    try:
        return metric.Options()
    except ValidationError:
        return None


def supported_metrics(loop) -> list[str]:
    """Metrics defined on ``loop`` (with default options, or none for metrics whose
    options have no defaults)."""
    return [name for name in METRIC_PATHS
            if metric_class(name)().supports(loop, _default_options(metric_class(name)()))]


def plant_configuration(params) -> str:
    """A plant's configuration for people: its type and every choice field (a ``Literal``,
    e.g. ``technique``) that is required or not at its default, ``software_servo(technique=
    sampled_data, model=pade)``. The metrics a loop supports depend on these choices."""
    choices = []
    for name, info in type(params).model_fields.items():
        if name == "type" or get_origin(info.annotation) is not Literal:
            continue
        value = getattr(params, name)
        if info.is_required() or value != info.default:
            choices.append(f"{name}={value}")
    return params.type + (f"({', '.join(choices)})" if choices else "")


def _optimisable_metrics(loop) -> list[str]:
    """Metrics that can be objective terms or constraints on ``loop`` (options as in
    :func:`supported_metrics`)."""
    return [name for name in supported_metrics(loop)
            if metric_class(name)().optimisable(loop, _default_options(metric_class(name)()))]


_ROBUST = TypeAdapter(RobustSpec)


def _robust_errors(raw: dict, plant_params, plant, moved: set[str]) -> list[tuple[str, str]]:
    """The uncertain parameters (``raw["robust"]``, canonical) against the plant: each one a
    number of its loop (:meth:`~feedtune.plants.base.Plant.numbers`), its nominal value one
    of its values, each value one the plant accepts; and the first solve's scenarios within
    :data:`~feedtune.schema.uncertainty.MAX_SCENARIOS`. Each named where the spec wrote it
    (``moved``: in ``plant``)."""
    robust = _valid(_ROBUST, raw.get("robust"))
    if robust is None:
        return []

    def where(name: str, *inner) -> str:
        base = ("plant", *number_path(name)) if name in moved else ("robust", "parameters", name)
        return "/" + "/".join(_escape(str(part)) for part in (*base, *inner))

    if not robust.parameters:
        return [("/robust/parameters", "no uncertain plant parameter: give one here or in "
                                       "'plant' as a list or a range")]
    errors = []
    if getattr(plant_params, "integer_ratio", False):
        errors.append(("/robust", "robust tuning and integer_ratio are not solved together "
                                  "(each rounds its own way): give one of them"))
    numbers = plant.numbers()
    certain = plant.not_uncertain()
    nominal = plant_params.model_dump()
    for name, uncertain in robust.parameters.items():
        field = number_path(name)[0]
        if name not in numbers and (field not in type(plant_params).model_fields
                                    or field == "type"):
            errors.append((where(name), f"unknown parameter of plant {plant_params.type!r}"))
            continue
        if name not in numbers:
            reason = certain.get(name) or certain.get(field) or (
                "it does not enter the loop as a number (it is not given, unused, or it "
                "shapes the model)")
            errors.append((where(name), (
                f"{name} cannot be uncertain in this plant configuration: {reason}; "
                f"uncertain parameters here: {', '.join(sorted(numbers)) or 'none'}")))
            continue
        pointer = "/" + "/".join(_escape(str(part)) for part in ("plant", *number_path(name)))
        if not uncertain.contains(numbers[name]):
            errors.append((where(name), f"the nominal value {numbers[name]} (in {pointer}) "
                                        "is not one of its values"))
        low, high = ((uncertain.min, uncertain.max) if uncertain.is_range()
                     else (min(uncertain.values), max(uncertain.values)))
        problem = plant.uncertainty_problem(name, low, high)
        if problem is not None:
            errors.append((where(name), problem))
            continue
        values = ({"min": uncertain.min, "max": uncertain.max} if uncertain.is_range()
                  else {str(i): v for i, v in enumerate(uncertain.values)})
        for inner, value in values.items():
            try:
                type(plant_params).model_validate(with_numbers(nominal, {name: value}))
            except ValidationError as exc:
                message = "; ".join(e["msg"].removeprefix("Value error, ") for e in exc.errors())
                if name in moved and not uncertain.is_range():
                    errors.append((where(name, inner), f"{value}: {message}"))
                else:
                    errors.append((where(name, *(("values",) if not uncertain.is_range()
                                                 else ()), inner), f"{value}: {message}"))
    count = scenario_count(robust)
    if not errors and count > MAX_SCENARIOS:
        errors.append(("/robust" if not moved else "/plant", (
            f"{count} scenarios (the nominal plant, every combination of the sets' values "
            f"and the ranges' ends, and {robust.interior_samples} interior samples) exceed "
            f"the limit of {MAX_SCENARIOS}: give fewer values or fewer uncertain parameters")))
    return errors


def _arithmetic_words(exc: ArithmeticError) -> str:
    """What went wrong, for a spec's author: Python's exception names and texts ("float
    division by zero") are not JSON's words (tests/property/test_spec_parsing.py)."""
    if isinstance(exc, ZeroDivisionError):
        return "a number underflows to 0 and is then divided by"
    if isinstance(exc, OverflowError):
        return "a number overflows"
    return "an arithmetic error"


def _semantic_errors(raw: dict, moved: set[str] = frozenset()) -> list[tuple[str, str]]:
    """Checks that need the registries, run on every part of ``raw`` (the canonical spec:
    uncertain forms in ``robust``; ``moved`` the ones written in ``plant``) that validates
    by itself: tunable names and bounds, metric applicability, the step-response horizon,
    the uncertain parameters."""
    plant_params = _valid(_PLANT, raw.get("plant"))
    if plant_params is None:
        return []
    plant = plant_for(plant_params)
    errors = _robust_errors(raw, plant_params, plant, moved)
    tunables = plant.tunables()
    raw_tunables = raw.get("tunables")
    fixed = plant.not_tunable()
    for name in raw_tunables if isinstance(raw_tunables, dict) else ():
        if name in fixed:
            errors.append((f"/tunables/{_escape(name)}", fixed[name]))
        elif name not in tunables:
            errors.append((f"/tunables/{_escape(name)}",
                           f"unknown tunable for this plant; known: {', '.join(tunables)}"))
    given = raw_tunables if isinstance(raw_tunables, dict) else {}
    errors += [(f"/tunables/{_escape(name)}", f"required by this plant configuration "
                                              f"[{tunable.unit}]: give min/max or a value")
               for name, tunable in tunables.items() if tunable.required and name not in given]
    box, box_errors, box_complete = tunable_box(raw_tunables, tunables)
    errors += box_errors
    constraints = raw.get("constraints")
    if (getattr(plant_params, "integer_ratio", False) and isinstance(constraints, list)
            and len(constraints) == MAX_CONSTRAINTS):
        errors.append(("/constraints", f"at most {MAX_CONSTRAINTS - 1} constraints with "
                                       "integer_ratio, which adds one (q = a whole number)"))
    try:
        loop = plant.checked_loop({n: hi for n, (lo, hi) in box.items()}, box)
    except SampledModelError as exc:  # "<pointer>: <message>" (feedtune.plants.linear)
        pointer, _, message = str(exc).partition(": ")
        return errors + [(pointer, message)]
    except ArithmeticError as exc:  # e.g. D_m = 1e-300: D_m² underflows to 0, then K/D_m²
        return errors + [("/plant", "the plant's numbers leave double precision when the "
                                    f"loop is formed ({_arithmetic_words(exc)}); give "
                                    "them in SI units within about 1e-150 … 1e150")]
    supported = optimisable = None  # computed when a message needs them
    for section, adapter in _TERM.items():
        terms = raw.get(section)
        limit = MAX_OBJECTIVE_TERMS if section == "objective" else MAX_CONSTRAINTS
        for i, item in enumerate(terms[:limit] if isinstance(terms, list) else ()):
            where = f"/{section}/{i}/metric"
            term = _valid(adapter, item)
            name = item.get("metric") if isinstance(item, dict) else None
            if term is None and not (isinstance(name, str) and name in METRIC_PATHS):
                continue  # the schema errors say what is wrong with it
            metric = metric_class(name)()
            options = term if term is not None else _default_options(metric)
            if options is None:
                continue  # a term whose options did not validate and have no defaults
            if not metric.supports(loop, options):
                supported = supported if supported is not None else supported_metrics(loop)
                errors.append((where, f"metric {json.dumps(name)} is not defined for this "
                                      f"plant configuration, {plant_configuration(plant_params)}"
                                      " (`feedtune metrics` lists the plants that support "
                                      "each metric); supported here: "
                                      f"{', '.join(supported) or 'none'}"))
            elif term is not None and not metric.optimisable(loop, term):
                optimisable = optimisable if optimisable is not None else _optimisable_metrics(loop)
                errors.append((where,
                               f"metric {json.dumps(name)} is reported only on this plant "
                               "configuration: evaluated on the tuned design, it cannot be an "
                               "objective term or a constraint; optimisable here: "
                               f"{', '.join(optimisable) or 'none'}"))
            elif (section == "objective" and term is not None and box_complete
                  and metric.infinite_when and _infinite_over_box(plant, box, loop, metric, term)):
                errors.append((where, f"metric {json.dumps(name)} is +∞ at the low and high "
                                      "corners and the centre of the tunables' box ("
                                      f"{metric.infinite_when}): as an objective term it has "
                                      "no finite optimum; hold it with a constraint ('min') "
                                      "instead, which +∞ meets"))
            elif term is not None and box_complete and _sums_exact_steps(metric, loop, term):
                if not loop.offers(Capability.SAMPLE_HORIZON):
                    continue  # a continuous loop's integrals are closed-form lobe sums
                try:
                    _tuner_horizon_samples(plant, box, loop)
                except HorizonError as exc:
                    errors.append((where, f"{name} sums the step response sample by sample: "
                                          f"{exc}"))
    return errors


#: the module of the metrics that sum a step response sample by sample
_STEP_ERROR = "feedtune.objectives.time.step_error"


def _sums_exact_steps(metric, loop, options) -> bool:
    """Whether ``metric`` is a :class:`~feedtune.objectives.time.step_error.StepErrorMetric`
    whose step responses on ``loop`` are exact (``has_exact_step``). That module is imported
    by every such metric's module, so a spec that names none never loads it (nor the step
    responses it imports)."""
    module = sys.modules.get(_STEP_ERROR)
    return (module is not None and isinstance(metric, module.StepErrorMetric)
            and module.has_exact_step(loop, options))


def _infinite_over_box(plant, box: dict, loop, metric, options) -> bool:
    """Whether ``metric`` (one with :attr:`~feedtune.objectives.base.Metric.infinite_when`)
    is +∞ on ``loop`` (the box's high corner) and on the loops at the box's low corner and
    geometric centre: a sample, which finds a quantity that the loop's structure never
    has (Koren's K/(s(1 + sτ)) has no phase crossover at any K). False where a loop
    cannot be evaluated (the tuner then reports what it finds)."""
    corners = [{n: lo for n, (lo, hi) in box.items()},
               {n: math.sqrt(lo * hi) for n, (lo, hi) in box.items()}]
    try:
        for point in [loop, *(plant.loop(values, box) for values in corners)]:
            value = metric.evaluate(point, options)
            if to_float(value.exact if isinstance(value, Unbounded) else value) != math.inf:
                return False
    except (ArithmeticError, RuntimeError, ValueError):
        return False
    return True


def parse_spec(data: bytes | str | dict) -> Spec:
    """Validate a spec (JSON text, bytes or an already parsed dict).

    Every problem is found in one pass: the schema's, and the checks that need the
    plant and metric registries on every part that validated.

    Raises
    ------
    SpecError
        With one (JSON pointer, message) per problem found.
    """
    raw = data if isinstance(data, dict) else load_json(data)
    if not isinstance(raw, dict):
        raise SpecError([("", f"a spec is a JSON object, not {json_type(raw)}")])
    plant = raw.get("plant")
    if isinstance(plant, dict) and isinstance(plant.get("type"), str) and \
            plant["type"] in DATA_PLANTS:  # measured data: the convex technique
        from feedtune.measured.datadriven_spec import parse_data_spec

        return parse_data_spec(raw)
    canonical, moved, problems = move_inline_forms(raw, PLANT_MODELS)
    schema, spec = [], None
    forms = [(_pointer(loc, raw), message) for loc, message in problems]
    try:
        # strict: a string is not a number, nor true a count (JSON has the types to say so)
        spec = Spec.model_validate(canonical, strict=True)
    except ValidationError as exc:
        schema = _schema_errors(exc, raw, moved)
    errors = _merged(_merged(forms, schema), _semantic_errors(canonical, moved))
    if errors:
        raise SpecError(errors)
    return spec


def printable(text: str) -> str:
    """``text`` with control characters escaped as in JSON (``\\n``, ``\\u001b``): what a
    spec puts into a message (a key in a pointer) cannot start a new log line."""
    return _CONTROL.sub(lambda m: json.dumps(m.group())[1:-1], text)


def spec_json_schema() -> dict:
    """JSON Schema of the spec, with units in the field descriptions."""
    return Spec.model_json_schema()
