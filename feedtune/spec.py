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
from typing import Annotated, Any, Literal, Union

from pydantic import Field, PositiveFloat, PositiveInt, ValidationError, create_model, model_validator

from feedtune.model import SpecModel
from feedtune.objectives import METRICS
from feedtune.plants import PLANTS, plant_for

MAX_SPEC_BYTES = 1_000_000
MAX_JSON_DEPTH = 32


class SpecError(ValueError):
    """A spec that cannot be used; ``errors`` is a list of (JSON pointer, message)."""

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
                          "build; null (default) expands when step responses are short")
    ipopt_options: dict[str, str | int | float] = Field(
        default_factory=dict, description="Raw IPOPT options, passed through unchanged")


def _camel(name: str) -> str:
    return "".join(part.capitalize() for part in name.split("_"))


def _objective_model(name, metric):
    return create_model(
        f"{_camel(name)}Objective", __base__=metric.Options,
        metric=(Literal[name], Field(description=metric.description)),
        weight=(PositiveFloat, Field(1.0, description=f"Weight of this term [1/({metric.unit})]")),
        goal=(Literal["minimize", "maximize"], Field(
            "minimize", description="minimize: add weight·value to the objective; maximize: "
                                    "subtract it (e.g. bandwidth)")),
    )


def _constraint_model(name, metric):
    def _has_bound(self):
        if self.min is None and self.max is None:
            raise ValueError("a constraint needs 'min', 'max' or both")
        if self.min is not None and self.max is not None and self.min > self.max:
            raise ValueError(f"min ({self.min}) is greater than max ({self.max})")
        return self

    return create_model(
        f"{_camel(name)}Constraint", __base__=metric.Options,
        __validators__={"_has_bound": model_validator(mode="after")(_has_bound)},
        metric=(Literal[name], Field(description=metric.description)),
        min=(float | None, Field(None, description=f"Lower bound [{metric.unit}]")),
        max=(float | None, Field(None, description=f"Upper bound [{metric.unit}]")),
    )


def _tagged_union(models: tuple, tag: str):
    """Discriminated union of ``models`` on field ``tag`` (a single model stands alone)."""
    if len(models) == 1:
        return models[0]
    return Annotated[Union[models], Field(discriminator=tag)]


PlantSpec = _tagged_union(tuple(plant.Params for plant in PLANTS.values()), "type")
ObjectiveTerm = _tagged_union(tuple(_objective_model(n, m) for n, m in METRICS.items()), "metric")
ConstraintSpec = _tagged_union(tuple(_constraint_model(n, m) for n, m in METRICS.items()), "metric")


class Spec(SpecModel):
    """A tuning problem: plant, tunables, objective, constraints, solver."""

    name: str = Field(min_length=1, max_length=200, description="Name of this tuning problem")
    description: str = Field("", max_length=10_000, description="Free text for people")
    plant: PlantSpec
    tunables: dict[str, TunableSpec] = Field(
        default_factory=dict,
        description="Tunables by name (see `feedtune plants`); omitted ones are free within "
                    "the plant's default bounds")
    objective: list[ObjectiveTerm] = Field(min_length=1, description="Weighted sum of metric terms to minimise (terms with goal maximize count negatively)")
    constraints: list[ConstraintSpec] = Field(default_factory=list, description="Metric bounds that must hold")
    solver: SolverSpec = Field(default_factory=SolverSpec)

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
    """Parse strict JSON (no NaN/Infinity, no duplicate keys, UTF-8, size-limited)."""
    if isinstance(data, bytes):
        if len(data) > MAX_SPEC_BYTES:
            raise SpecError([("", f"spec is {len(data)} bytes; the limit is {MAX_SPEC_BYTES}")])
        try:
            data = data.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise SpecError([("", f"spec is not UTF-8 text (byte {exc.start})")]) from None
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


#: discriminator values pydantic puts into error locations (a lone model has no tag)
_UNION_TAGS = (set(PLANTS) if len(PLANTS) > 1 else set()) | (set(METRICS) if len(METRICS) > 1 else set())


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
            if not tag_seen and item == tag and item in _UNION_TAGS:
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


def _ipopt_option_errors(options: dict) -> list[tuple[str, str]]:
    """Unknown IPOPT options and values of the wrong type, found by IPOPT itself."""
    errors = []
    for name, value in options.items():
        reason = _ipopt_option_error(name, value)
        if reason is not None:
            errors.append((f"/solver/ipopt_options/{_escape(name)}", f"IPOPT rejects it: {reason}"))
    return errors


@functools.lru_cache(maxsize=256, typed=True)  # typed: IPOPT tells 1, 1.0 and "1" apart
def _ipopt_option_error(name: str, value: str | int | float) -> str | None:
    """IPOPT's reason for rejecting ``name = value``, or None; one nlpsol per pair and process."""
    import casadi as ca

    x = ca.MX.sym("x")
    try:
        ca.nlpsol("option_check", "ipopt", {"x": x, "f": x**2},
                  {"ipopt": {name: value, "print_level": 0, "sb": "yes"}, "print_time": False})
    except RuntimeError as exc:
        return str(exc).strip().splitlines()[-1].split(": ", 1)[-1]
    return None


def _semantic_errors(spec: Spec) -> list[tuple[str, str]]:
    """Checks that need the registries: tunable names and bounds, metric applicability."""
    errors = _ipopt_option_errors(spec.solver.ipopt_options)
    plant = plant_for(spec.plant)
    tunables = plant.tunables()
    for name, tunable in spec.tunables.items():
        if name not in tunables:
            errors.append((f"/tunables/{_escape(name)}",
                           f"unknown tunable for this plant; known: {', '.join(tunables)}"))
    loop = plant.loop({n: t.max for n, t in tunables.items()},
                      {n: (t.min, t.max) for n, t in tunables.items()})
    optimisable = None  # names of the metrics this loop can optimise, computed when needed
    for section in ("objective", "constraints"):
        for i, term in enumerate(getattr(spec, section)):
            metric = METRICS[term.metric]()
            if not metric.supports(loop, term):
                errors.append((f"/{section}/{i}/metric",
                               f"metric {term.metric!r} is not defined for this plant configuration"))
            elif not metric.optimisable(loop, term):
                if optimisable is None:
                    optimisable = _optimisable_metrics(loop)
                errors.append((f"/{section}/{i}/metric",
                               f"metric {term.metric!r} is reported only on this plant "
                               "configuration: evaluated on the tuned design, it cannot be an "
                               "objective term or a constraint; optimisable here: "
                               f"{', '.join(optimisable) or 'none'}"))
    return errors


def _optimisable_metrics(loop) -> list[str]:
    """Metrics that can be objective terms or constraints on ``loop`` (default options, or
    none for metrics whose options have no defaults)."""
    names = []
    for name, metric_cls in METRICS.items():
        metric = metric_cls()
        try:
            options = metric.Options()
        except ValidationError:
            options = None
        if metric.supports(loop, options) and metric.optimisable(loop, options):
            names.append(name)
    return names


def parse_spec(data: bytes | str | dict) -> Spec:
    """Validate a spec (JSON text, bytes or an already parsed dict).

    Raises
    ------
    SpecError
        With one (JSON pointer, message) per problem found.
    """
    raw = data if isinstance(data, dict) else load_json(data)
    if not isinstance(raw, dict):
        raise SpecError([("", f"a spec is a JSON object, not {type(raw).__name__}")])
    try:
        # strict: a string is not a number, nor true a count (JSON has the types to say so)
        spec = Spec.model_validate(raw, strict=True)
    except ValidationError as exc:
        raise SpecError(_errors_by_pointer([(_pointer(e["loc"], raw),
                                             e["msg"].removeprefix("Value error, "))
                                            for e in exc.errors()])) from None
    errors = _semantic_errors(spec)
    if errors:
        raise SpecError(errors)
    return spec


def spec_json_schema() -> dict:
    """JSON Schema of the spec, with units in the field descriptions."""
    return Spec.model_json_schema()
