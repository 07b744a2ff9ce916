"""The ``feedtune`` command line.

``feedtune tune SPEC`` writes the result JSON, and only that, to stdout (or ``-o``);
everything meant for people (the summary, errors, anything IPOPT or CasADi print)
goes to stderr. Exit status: 0 a successful tuning, 1 a result with ``success`` false
(still written), 2 a spec or file that cannot be used, 3 an internal error, 130
interrupted.
"""

from __future__ import annotations

import contextlib
import ctypes
import itertools
import json
import math
import os
import re
import signal
import sys
import traceback
import typing
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterator

import click

from feedtune import __version__, interrupts
from feedtune.files import write_atomic

if TYPE_CHECKING:  # pydantic is imported by the commands that read specs, not by --help
    from pydantic.fields import FieldInfo

#: exit statuses, also listed in ``feedtune --help``
EXIT_OK, EXIT_NOT_SUCCESS, EXIT_BAD_INPUT, EXIT_INTERNAL = 0, 1, 2, 3

STDIN = "-"

_EPILOG = ("Exit status: 0 success; 1 the tuning did not succeed (the result is still "
           "written); 2 the spec or a file cannot be used; 3 internal error (please report).")


# -- small helpers -----------------------------------------------------------------------

def _err(message: str = "") -> None:
    click.echo(message, err=True)


def _fail(message: str, code: int = EXIT_BAD_INPUT) -> typing.NoReturn:
    _err(f"error: {message}")
    raise SystemExit(code)


def _spec_errors(label: str, errors: list[tuple[str, str]]) -> typing.NoReturn:
    """One ``error: LABEL: POINTER: message`` line per problem, then exit 2."""
    from feedtune.spec import printable

    for pointer, message in errors:
        where = f"{label}: {printable(pointer)}" if pointer else label
        _err(f"error: {where}: {printable(message)}")
    raise SystemExit(EXIT_BAD_INPUT)


def _label(spec: str) -> str:
    return "<stdin>" if spec == STDIN else spec


def _read_spec(spec: str) -> bytes:
    """The bytes of SPEC (a path or ``-``), or exit 2 with the reason it cannot be read."""
    from feedtune.spec import MAX_SPEC_BYTES

    try:
        if spec == STDIN:
            data = click.get_binary_stream("stdin").read(MAX_SPEC_BYTES + 1)
        else:
            with open(spec, "rb") as handle:
                data = handle.read(MAX_SPEC_BYTES + 1)
    except FileNotFoundError:
        _fail(f"{_label(spec)}: no such file")
    except IsADirectoryError:
        _fail(f"{_label(spec)}: is a directory, not a spec file")
    except PermissionError:
        _fail(f"{_label(spec)}: permission denied")
    except OSError as exc:
        _fail(f"{_label(spec)}: cannot read: {exc.strerror or exc}")
    if len(data) > MAX_SPEC_BYTES:
        _fail(f"{_label(spec)}: spec is larger than the limit of {MAX_SPEC_BYTES} bytes")
    return data


def _parse(spec: str):
    """Read and parse SPEC, or print its errors and exit 2."""
    from feedtune.spec import SpecError, parse_spec

    data = _read_spec(spec)
    try:
        return parse_spec(data)
    except SpecError as exc:
        _spec_errors(_label(spec), exc.errors)


def _check_output(output: str | None) -> Path | None:
    """The output path (None for stdout); exit 2 now if it cannot be written later."""
    if output is None or output == STDIN:
        return None
    path = Path(output)
    if path.is_dir():
        _fail(f"{output}: is a directory; give a file name for the output")
    if not path.parent.is_dir():
        _fail(f"{output}: directory {str(path.parent)!r} does not exist")
    return path


def _emit(data: bytes, path: Path | None) -> None:
    """``data`` to stdout (path None) or atomically to ``path``; exit 2 if that fails."""
    if path is None:
        stream = click.get_binary_stream("stdout")
        stream.write(data)
        stream.flush()
        return
    try:
        write_atomic(path, data)
    except OSError as exc:
        _fail(f"{path}: cannot write: {exc.strerror or exc}")


def _flush_c_stdio() -> None:
    """Flush the C library's stdio buffers (IPOPT writes through them)."""
    with contextlib.suppress(Exception):
        ctypes.CDLL(None).fflush(None)


@contextlib.contextmanager
def _stdout_to_stderr() -> Iterator[None]:
    """Send everything written to file descriptor 1 (C or Python) to stderr meanwhile."""
    sys.stdout.flush()
    _flush_c_stdio()
    try:
        saved = os.dup(1)
    except OSError:  # no file descriptor 1: nothing to protect
        saved = None
    if saved is not None:
        try:
            os.dup2(2, 1)
        except OSError:  # no file descriptor 2: send the solver's chatter nowhere
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, 1)
            os.close(devnull)
    try:
        with contextlib.redirect_stdout(sys.stderr):
            yield
    finally:
        sys.stderr.flush()
        _flush_c_stdio()
        if saved is not None:
            os.dup2(saved, 1)
            os.close(saved)


def _g(value: float | None) -> str:
    return "n/a" if value is None else f"{value:.6g}"


def _unit(unit: str) -> str:
    return f"[{unit}]"


# -- describing registries ---------------------------------------------------------------

_UNIT = re.compile(r"\[([^\[\]]+)\]")


def _unit_of(description: str | None) -> str | None:
    """The first ``[unit]`` in a field description, if any."""
    match = _UNIT.search(description or "")
    return match.group(1) if match else None


def _choices(annotation: Any) -> list | None:
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


def _describe_fields(model) -> list[dict]:
    fields = []
    for name, info in model.model_fields.items():
        required, default = _default(info)
        fields.append({
            "name": name,
            "description": info.description or "",
            "unit": _unit_of(info.description),
            "required": required,
            "default": default,
            "choices": _choices(info.annotation),
            "limits": _limits(info),
        })
    return fields


def _first_line(text: str | None) -> str:
    return (text or "").strip().splitlines()[0] if (text or "").strip() else ""


def _techniques(params_model) -> list | None:
    info = params_model.model_fields.get("technique")
    return _choices(info.annotation) if info is not None else None


def _plant_tunables(name: str, plant_cls) -> dict[str, dict]:
    """Tunables of ``plant_cls`` per technique ("*" when the plant has no techniques).

    Each lists every tunable some choice of the plant's other Literal fields (e.g. a
    compensator kind) brings in, so ``velocity_compensator.tau1`` is listed although the
    default (no compensator) has none.
    """
    params_model = plant_cls.Params
    techniques = _techniques(params_model)
    choices = {field: _choices(info.annotation) for field, info in params_model.model_fields.items()
               if field not in ("type", "technique") and _choices(info.annotation)}
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


def describe_plants() -> dict[str, dict]:
    """Every registered plant: parameters and, per technique, tunables with default bounds."""
    from feedtune.plants import PLANTS

    plants = {}
    for name, plant_cls in PLANTS.items():
        module = sys.modules.get(plant_cls.__module__)
        plants[name] = {
            "summary": _first_line(getattr(module, "__doc__", None)),
            "reference": _first_line(plant_cls.Params.__doc__),
            "parameters": _describe_fields(plant_cls.Params),
            "tunables": _plant_tunables(name, plant_cls),
        }
    return plants


def _plant_configurations() -> dict[str, list]:
    """Plant configuration (:func:`feedtune.spec.plant_configuration`) → plant objects to
    probe: the plant of every bundled example and of every registered plant's defaults,
    each also with every other value of each of its choice fields (``technique``,
    ``model``, ...), those that validate."""
    from pydantic import ValidationError

    from feedtune.plants import PLANTS, plant_for
    from feedtune.spec import plant_configuration

    bases = [{"type": name} for name in PLANTS]
    for path in _examples().values():
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
    ``reported_only`` (those of them where it cannot be an objective or a constraint).

    Computed, not written down: each registered metric's ``supports`` and ``optimisable``
    asked on the loop of each configuration of :func:`_plant_configurations` (default
    tunable bounds, at their upper ends, as a spec's check builds it), with the metric's
    default options (none for options without defaults). A configuration counts when any
    of its probed plants supports the metric (a metric may also need a parameter, such as
    ``blu``, or a loop order).
    """
    from feedtune.objectives import METRICS
    from feedtune.spec import _default_options, tunable_box

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
    return support


def describe_metrics() -> dict[str, dict]:
    """Every registered metric: unit, description, reference, options, and the plant
    configurations that support it (:func:`metric_support`)."""
    from feedtune.objectives import METRICS

    support = metric_support()
    return {
        name: {"unit": m.unit, "description": m.description, "reference": m.reference,
               "options": _describe_fields(m.Options), **support[name]}
        for name, m in METRICS.items()}


def _field_lines(fields: list[dict], indent: str) -> list[str]:
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


# -- examples ----------------------------------------------------------------------------

def examples_dir() -> Path:
    """Bundled example specs: ``feedtune/examples`` in a wheel, ``examples/`` in the repo."""
    import feedtune

    package = Path(feedtune.__file__).resolve().parent
    bundled = package / "examples"
    return bundled if bundled.is_dir() else package.parent / "examples"


def _examples() -> dict[str, Path]:
    directory = examples_dir()
    if not directory.is_dir():
        return {}
    return {p.stem: p for p in sorted(directory.glob("*.json")) if p.is_file()}


#: a sentence ends at ". " after a word of two lower-case letters or digits ("… drive. The"),
#: not after an abbreviation such as "Ch. IV" or "Fig. 3"
_SENTENCE_END = re.compile(r"(?<=[a-z0-9)][a-z0-9)])\.\s+(?=[A-Z])")


def _shorten(text: str, width: int = 90) -> str:
    text = " ".join(text.split())
    sentence = _SENTENCE_END.split(text)[0].rstrip(".")
    if len(sentence) <= width:
        return sentence
    return sentence[: width - 1].rstrip() + "…"


def _example_description(path: Path) -> str:
    try:
        data = json.loads(path.read_bytes())
        return str(data.get("description", "")) if isinstance(data, dict) else ""
    except (OSError, ValueError):
        return "(unreadable)"


# -- commands ----------------------------------------------------------------------------

@click.group(context_settings={"help_option_names": ["-h", "--help"]}, epilog=_EPILOG)
@click.version_option(__version__, "-V", "--version", prog_name="feedtune")
def main() -> None:
    """Tune CNC feed drives (gains [1/s], sampling periods [s], compensators) by
    optimisation with CasADi and IPOPT.

    A JSON spec names the plant, which tunables are free, what to minimise and what
    must hold; all values are SI. Start with `feedtune examples`, `feedtune plants`
    and `feedtune metrics`.
    """
    with contextlib.suppress(AttributeError, ValueError):
        sys.stderr.reconfigure(errors="backslashreplace")
    if click.get_current_context().invoked_subcommand != "batch":  # batch: its _Stop does
        interrupts.release()


def _report_start(start, total: int) -> None:
    """One stderr line per multistart start, so long tunings show progress."""
    _err(f"start {start.index + 1}/{total}: {_start_text(start)}")


def _start_text(start) -> str:
    """What one start did, in words: a start without a stable point was never solved."""
    if start.return_status == "No_Stable_Start":
        return (f"no stable start (restoration found no stable loop near this point; not "
                f"solved), {start.solve_time:.3f} s")
    if start.return_status == "No_Free_Tunables":
        return "nothing to solve (every tunable fixed); evaluated"
    objective = "-" if start.objective is None else _g(start.objective)
    feasible = "" if start.feasible else " but violates a constraint or stability"
    return (f"{start.status}{feasible}, objective {objective}, {start.iterations} iterations, "
            f"{start.solve_time:.3f} s")


@main.command(epilog=_EPILOG)
@click.argument("spec", metavar="SPEC")
@click.option("-o", "--output", metavar="RESULT",
              help="Write the result JSON here (atomically) instead of stdout; '-' is stdout.")
@click.option("-q", "--quiet", is_flag=True, help="Do not print the summary to stderr.")
@click.option("--report", "report_dir", metavar="DIR",
              help="Also write the report (report.html and PNG figures, as `feedtune report`) "
                   "into DIR, created if missing; checked before solving, exit 2 if DIR holds "
                   "a file of the report's names that an earlier report did not write.")
def tune(spec: str, output: str | None, quiet: bool, report_dir: str | None) -> None:
    """Solve the tuning problem in SPEC (a JSON file, or '-' for stdin).

    The result (tuned values with their units, every metric, constraints, stability,
    IPOPT's status, provenance) is written as JSON, and nothing else, to stdout or
    RESULT. A summary for people, and anything the solver prints, goes to stderr.
    """
    from feedtune.spec import SpecError

    target = _check_output(output)
    report_path = _check_report_dir(report_dir)
    try:
        with _stdout_to_stderr():
            parsed = _parse(spec)
            from feedtune.api import tune as run_tune  # after parsing: slow import

            # the CLI's own process pins BLAS by its environment (feedtune.__main__)
            result = run_tune(parsed, progress=None if quiet else _report_start,
                              notify=None if quiet else _err, threads=None)
    except SpecError as exc:
        _spec_errors(_label(spec), exc.errors)
    except KeyboardInterrupt:
        _fail("interrupted; no result written", 130)
    except Exception as exc:  # a bug: say so, keep the traceback for the report
        traceback.print_exc()
        _fail(f"internal error in feedtune {__version__} ({type(exc).__name__}: {exc}); "
              "please report it with the spec", EXIT_INTERNAL)
    # first: a closed stderr must not lose the result
    _emit(result.to_json().encode("utf-8"), target)
    if not quiet:
        _err(result.summary())
    if target is not None and not quiet:
        _err(f"wrote {target}")
    from feedtune.validate import warning_lines

    for line in warning_lines(result.validation):  # also with --quiet: they are warnings
        _err(line)
    for line in result.warnings:
        _err(f"warning: implausible: {line}")
    if report_path is not None:
        _write_report(result, report_path, quiet)
    raise SystemExit(EXIT_OK if result.success else EXIT_NOT_SUCCESS)


def _check_report_dir(report_dir: str | None, option: str = "--report") -> Path | None:
    """The report directory, checked before any work: a directory or a new one's path."""
    if report_dir is None:
        return None
    path = Path(report_dir)
    if path.exists() and not path.is_dir():
        raise click.BadParameter(f"{report_dir}: exists and is not a directory",
                                 param_hint=f"'{option}'")
    if not path.exists() and not path.parent.is_dir():
        raise click.BadParameter(f"{report_dir}: its parent directory does not exist",
                                 param_hint=f"'{option}'")
    if path.is_dir():
        from feedtune.report import ReportDirError, check_out_dir

        try:
            check_out_dir(path)
        except ReportDirError as exc:
            raise click.BadParameter(str(exc), param_hint=f"'{option}'") from None
    return path


def _write_report(result, out: Path, quiet: bool) -> None:
    """Draw ``result``'s report (:meth:`feedtune.api.Result.report`) into ``out``."""
    from feedtune.report import ReportDirError

    try:
        written = result.report(out)
    except ReportDirError as exc:  # a file appeared since the check
        _fail(str(exc))
    if not quiet:
        drawn = len(written.figures)
        left_out = [f"{stem} ({why})" for stem, why in written.left_out.items()]
        _err(f"wrote {written.page} ({drawn} figure{'s' if drawn != 1 else ''})"
             + ("; not drawn: " + "; ".join(left_out) if left_out else ""))


@main.command(epilog="Exit status: 0 report written; 2 the result cannot be read or the "
                     "directory cannot be used.")
@click.argument("result_file", metavar="RESULT")
@click.option("--out", "out", metavar="DIR", required=True,
              help="Directory for report.html (self-contained: figures embedded) and the "
                   "PNG figures; created if missing. Replaces only what an earlier report "
                   "wrote there (listed in DIR/.feedtune-report.json); exit 2 if a file of "
                   "the same name is someone else's.")
@click.option("-q", "--quiet", is_flag=True, help="Do not print what was written.")
def report(result_file: str, out: str, quiet: bool) -> None:
    """Plots and an HTML page of RESULT (a result JSON of `feedtune tune` or `batch`).

    Step and ramp responses (and the load-torque step where the plant has one) with the
    time metrics [s, and the axis' position unit], Bode diagrams of the open and closed
    loop with M_peak, bandwidth [rad/s] and margins, the circle test's radial deviation [m]
    magnified, the closed-loop poles (z-plane when sampled), and tables of tuned values,
    metrics, constraints and the validation gaps. Curves come from the independent
    validator model of the plant; a figure a plant cannot offer is left out with the
    reason on the page.
    """
    from feedtune.api import ResultError, load_result

    path = _check_report_dir(out, "--out")
    try:
        loaded = load_result(result_file)
    except (FileNotFoundError, ResultError) as exc:
        _fail(str(exc))
    _write_report(loaded, path, quiet)
    raise SystemExit(EXIT_OK)


@main.command(epilog=_EPILOG)
@click.argument("spec", metavar="SPEC")
def validate(spec: str) -> None:
    """Check SPEC (a JSON file, or '-' for stdin) without solving it.

    Checks the JSON, every field and unit range, tunable names, that each metric applies
    to the plant, that each tunable's bounds [its unit] are not empty, the IPOPT options'
    allow-list and the work limits (terms, constraints, step-response samples): exactly
    what `tune` refuses. Prints `ok: NAME` to stderr, or one
    `error: SPEC: /json/pointer: message` line per problem.
    """
    parsed = _parse(spec)
    _err(f"ok: {parsed.name}")  # a name holds printable characters only


@main.command()
def schema() -> None:
    """Print the JSON Schema of a spec (units are in the field descriptions)."""
    from feedtune.spec import spec_json_schema

    text = json.dumps(spec_json_schema(), indent=2, ensure_ascii=False) + "\n"
    _emit(text.encode("utf-8"), None)


@main.command()
@click.option("--json", "as_json", is_flag=True, help="Print JSON instead of text.")
def plants(as_json: bool) -> None:
    """List the plants: parameters (unit, default) and tunables with units and default
    bounds for each technique."""
    described = describe_plants()
    if as_json:
        _emit((json.dumps(described, indent=2, ensure_ascii=False) + "\n").encode("utf-8"), None)
        return
    lines = []
    for name, plant in described.items():
        lines.append(f"{name}: {plant['summary']}")
        if plant["reference"]:
            lines.append(f"  {plant['reference']}")
        lines.append("  parameters (plant.*):")
        lines.extend(_field_lines(plant["parameters"], "    "))
        for technique, tunables in plant["tunables"].items():
            heading = "tunables" if technique == "*" else f"tunables with technique {technique}"
            lines.append(f"  {heading} (default bounds):")
            width = max((len(t) for t in tunables), default=0)
            for tname, t in tunables.items():
                lines.append(f"    {tname:<{width}}  {_g(t['min'])} … {_g(t['max'])} "
                             f"{_unit(t['unit'])}  {t['description']}")
        lines.append("")
    click.echo("\n".join(lines).rstrip("\n"))


@main.command()
@click.option("--json", "as_json", is_flag=True, help="Print JSON instead of text.")
def metrics(as_json: bool) -> None:
    """List the metrics usable as objective terms or constraints, with units, references,
    options, and the plants and techniques that support each (asked of each metric on each
    plant configuration's loop: ``supported``, and ``reported_only`` where it cannot be an
    objective term or a constraint)."""
    described = describe_metrics()
    if as_json:
        _emit((json.dumps(described, indent=2, ensure_ascii=False) + "\n").encode("utf-8"), None)
        return
    configurations = list(_plant_configurations())
    lines = []
    for name, m in described.items():
        lines.append(f"{name} {_unit(m['unit'])}: {m['description']}")
        if m["reference"]:
            lines.append(f"  reference: {m['reference']}")
        if m["options"]:
            lines.append("  options:")
            lines.extend(_field_lines(m["options"], "    "))
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


@main.command()
@click.argument("name", required=False)
@click.option("-o", "--output", metavar="PATH",
              help="Copy the example spec here instead of printing it; '-' is stdout.")
def examples(name: str | None, output: str | None) -> None:
    """List the bundled example specs, or print (or copy) the one called NAME."""
    known = _examples()
    if name is None:
        if not known:
            _err(f"no examples found in {examples_dir()}")
            return
        width = max(len(stem) for stem in known)
        room = max(40, 100 - width - 2)  # lines of at most 100 characters
        for stem, path in known.items():
            click.echo(f"{stem:<{width}}  {_shorten(_example_description(path), room)}")
        return
    stem = name[:-5] if name.endswith(".json") else name
    if stem not in known:
        listing = ", ".join(known) or f"none (looked in {examples_dir()})"
        _fail(f"unknown example {name!r}; known: {listing}")
    target = _check_output(output)
    try:
        data = known[stem].read_bytes()
    except OSError as exc:
        _fail(f"{known[stem]}: cannot read: {exc.strerror or exc}")
    _emit(data, target)
    if target is not None:
        _err(f"wrote {target}")


# -- batch -------------------------------------------------------------------------------

_BATCH_EPILOG = ("Exit status: 0 every spec solved and met its constraints (and, with "
                 "--baseline, is not worse); 1 some spec did not; 2 the inputs, the output "
                 "directory, the baseline or the Dask cluster cannot be used; 130 "
                 "interrupted by Ctrl-C or SIGTERM (results so far are kept; rerun to "
                 "finish).")


@main.command(epilog=_BATCH_EPILOG)
@click.argument("inputs", nargs=-1, required=True, metavar="INPUT...")
@click.option("--out", "out", required=True, metavar="DIR",
              help="Directory for one result file per spec (NAME.json) and summary.json; "
                   "created if missing. Results already there for the same spec and feedtune "
                   "version are kept, not solved again.")
@click.option("--executor", type=click.Choice(["local", "dask"]), default=None,
              help="local (default): worker processes on this machine; dask: a dask.distributed "
                   "cluster, a local one unless --scheduler names one.")
@click.option("--scheduler", metavar="ADDRESS",
              help="Address of a running Dask scheduler, e.g. tcp://10.0.0.5:8786 "
                   "(implies --executor dask).")
@click.option("-j", "--workers", type=click.IntRange(min=1), default=None,
              help="Worker processes [count]; default: every core of this machine.")
@click.option("--timeout", type=click.FloatRange(min=0, min_open=True), default=None,
              metavar="SECONDS",
              help="Stop a spec that runs longer than this [s] (status timeout); local "
                   "executor only. Each IPOPT solve also has the spec's own solver.time_limit.")
@click.option("--junit", "junit", metavar="FILE",
              help="Also write JUnit XML: one test case per spec (its file and line), a "
                   "failure when it is invalid, unsolved, violates a constraint, fails the "
                   "independent validation or is worse than the baseline, with that reason "
                   "as its type.")
@click.option("--format", "output_format", type=click.Choice(["text", "github"]),
              default="text", show_default=True,
              help="github: also print GitHub Actions ::error annotations on stdout, one per "
                   "failing spec, naming its file.")
@click.option("--baseline", metavar="DIR",
              help="--out directory of an earlier batch: a spec whose objective is now worse "
                   "than there (beyond --baseline-rtol) fails.")
@click.option("--baseline-rtol", type=click.FloatRange(min=0), default=1e-6,
              show_default=True, metavar="RTOL",
              help="Relative tolerance of the baseline comparison [1].")
@click.option("--worker-timeout", type=click.FloatRange(min=0, min_open=True), default=60.0,
              show_default=True, metavar="SECONDS",
              help="Dask only: stop with exit status 2 when no worker has joined the scheduler "
                   "within this time [s]; also the time allowed to connect to it.")
@click.option("-q", "--quiet", is_flag=True,
              help="No progress and no table on stderr (the totals line is still printed).")
def batch(inputs: tuple[str, ...], out: str, executor: str | None, scheduler: str | None,
          workers: int | None, timeout: float | None, worker_timeout: float,
          junit: str | None, output_format: str, baseline: str | None, baseline_rtol: float,
          quiet: bool) -> None:
    """Tune many specs in parallel: one result per spec in DIR, plus DIR/summary.json.

    INPUT is a spec file (*.json), a JSON Lines file (*.jsonl, one spec per line), a
    directory (every *.json and *.jsonl below it) or a quoted glob pattern ('specs/**/*.json').
    A spec that is invalid, fails to solve, times out or kills its worker becomes a row with
    its status and message; the others still run.
    """
    stop = _Stop()  # first, before the slow imports: Ctrl-C or SIGTERM is exit 130 from here
    try:
        _batch(inputs, out, executor, scheduler, workers, timeout, worker_timeout, junit,
               output_format, baseline, baseline_rtol, quiet, stop)
    except KeyboardInterrupt:
        _interrupted()
    finally:
        stop.restore()


class _Stop:
    """Ctrl-C and SIGTERM (how CI cancels) during a batch, both a KeyboardInterrupt.

    While the batch loads (slow imports) a signal is only remembered: an exception raised
    inside an import can be swallowed ("Exception ignored in ...") or, inside an extension
    module's own Python code, make the interpreter exit by SIGINT whatever we then do.
    :meth:`arm` raises a remembered one, then lets later signals raise at once; :meth:`check`
    raises one that was swallowed anyway.
    """

    def __init__(self) -> None:
        self.requested = False
        self.previous = {signum: signal.signal(signum, self._remember)
                         for signum in (signal.SIGINT, signal.SIGTERM)}

    def _remember(self, signum, frame) -> None:
        self.requested = True

    def _raise(self, signum, frame) -> typing.NoReturn:
        self.requested = True
        raise KeyboardInterrupt

    def arm(self) -> None:
        self.check()
        for signum in (signal.SIGINT, signal.SIGTERM):
            signal.signal(signum, self._raise)

    def check(self) -> None:
        if self.requested:
            raise KeyboardInterrupt

    def restore(self) -> None:
        """The handlers from before, for a caller that goes on (tests calling in process)."""
        for signum, handler in self.previous.items():
            signal.signal(signum, handler)


def _interrupted() -> typing.NoReturn:
    for signum in (signal.SIGINT, signal.SIGTERM):  # a second signal must not cut this short
        signal.signal(signum, signal.SIG_IGN)
    _err("interrupted: the results written so far are kept; rerun the same command to finish")
    raise SystemExit(130)


def _batch(inputs: tuple[str, ...], out: str, executor: str | None, scheduler: str | None,
           workers: int | None, timeout: float | None, worker_timeout: float,
           junit: str | None, output_format: str, baseline: str | None, baseline_rtol: float,
           quiet: bool, stop: _Stop) -> None:
    """The batch command once its signal handling (``stop``) is in place."""
    if scheduler is not None and executor == "local":
        _fail("--scheduler needs the dask executor; drop --executor local")
    kind = "dask" if scheduler is not None else (executor or "local")
    if kind == "dask" and timeout is not None:
        _fail("--timeout is enforced by the local executor only; with Dask, each spec's "
              "solver.time_limit bounds its IPOPT solves")
    if kind == "dask":
        try:
            import distributed  # noqa: F401
        except ImportError:
            _fail("--executor dask and --scheduler need Dask, which is not installed: "
                  "pip install 'feedtune[dask]'")
    junit_path = _check_output(junit) if junit is not None else None

    from feedtune.batch.dask_cluster import DaskExecutor
    from feedtune.batch.inputs import InputError
    from feedtune.batch.local import LocalExecutor
    from feedtune.batch.progress import Progress
    from feedtune.batch.reports import (BaselineError, github_annotations, junit_xml,
                                        load_baseline, table, totals_line)
    from feedtune.batch.runner import run_batch

    baseline_rows = None
    if baseline is not None:
        try:
            baseline_rows = load_baseline(Path(baseline))
        except BaselineError as exc:
            _fail(str(exc))
    if kind == "dask":
        runner = DaskExecutor(scheduler, workers, worker_timeout=worker_timeout)
        header = {"executor": "dask", "scheduler": scheduler or "local cluster",
                  "workers": workers}
    else:
        runner = LocalExecutor(workers, timeout)
        header = {"executor": "local", "workers": runner.workers}
    progress = [None]

    def on_row(row: dict) -> None:
        stop.check()
        if progress[0] is not None:
            progress[0].update(row["ok"])

    class _Counted:  # starts the progress display once the number of specs is known
        def __init__(self, inner):
            self.inner = inner

        def run(self, tasks, on_outcome):
            progress[0] = Progress(len(tasks), enabled=not quiet)
            try:
                self.inner.run(tasks, on_outcome)
            finally:
                progress[0].close()

    stop.arm()
    try:
        with _stdout_to_stderr():
            outcome = run_batch(list(inputs), Path(out), _Counted(runner),
                                baseline=baseline_rows, baseline_rtol=baseline_rtol,
                                on_row=on_row, header=header)
    except InputError as exc:
        _fail(str(exc))
    except OSError as exc:
        _fail(f"{out}: {exc.strerror or exc}")
    if outcome.executor_error is not None:
        _fail(f"{outcome.executor_error} (summary: {Path(out) / 'summary.json'})")
    rows = outcome.document["rows"]
    if not quiet:
        for line in table(rows):
            _err(line)
    _err(totals_line(outcome.document, outcome.wall))
    if junit_path is not None:
        _emit(junit_xml(rows, outcome.wall), junit_path)
    if output_format == "github":
        for line in github_annotations(rows):
            click.echo(line)
    if outcome.interrupted or stop.requested:
        _interrupted()
    raise SystemExit(EXIT_OK if outcome.document["failed"] == 0 else EXIT_NOT_SUCCESS)


# -- Koren's charts and technique selection ------------------------------------------------

_CHART_EPILOG = ("Exit status: 0 chart written; 1 some points had no optimum (the chart is "
                 "still written, without them); 2 an option or output path cannot be used.")
_CHART_FORMATS = (".png", ".svg", ".pdf")
_POSITIVE = click.FloatRange(min=0, min_open=True)


def _chart_paths(out: str, data: str | None) -> tuple[Path, Path | None]:
    """The chart and data paths, checked before any computing; errors name the option."""
    path = Path(out)
    if path.suffix.lower() not in _CHART_FORMATS:
        raise click.BadParameter(f"{out}: the chart's format follows the suffix, one of "
                                 f"{', '.join(_CHART_FORMATS)}", param_hint="'--out'")
    if path.is_dir() or not path.parent.is_dir():
        raise click.BadParameter(f"{out}: not a file in an existing directory",
                                 param_hint="'--out'")
    data_path = None
    if data is not None:
        data_path = Path(data)
        if data_path.suffix.lower() not in (".json", ".csv"):
            raise click.BadParameter(f"{data}: the suffix must be .json or .csv",
                                     param_hint="'--data'")
        if data_path.is_dir() or not data_path.parent.is_dir():
            raise click.BadParameter(f"{data}: not a file in an existing directory",
                                     param_hint="'--data'")
    return path, data_path


def _check_range(low: float, high: float, low_name: str, high_name: str) -> None:
    if not low < high:
        raise click.BadParameter(f"{high:g} must be greater than {low_name} ({low:g})",
                                 param_hint=f"'{high_name}'")


def _write_chart(kind: str, data: dict, path: Path, data_path: Path | None, quiet: bool) -> None:
    import io

    from feedtune.charts.koren import PLOTS, write_data
    from feedtune.status import SKIPPED

    buffer = io.BytesIO()  # drawn in memory, then written atomically
    PLOTS[kind](data, buffer, path.suffix.lstrip(".").lower())
    _emit(buffer.getvalue(), path)
    if data_path is not None:
        _emit(write_data(data, data_path), data_path)
    if not quiet:
        seconds = data.get("seconds")
        took = f" in {seconds:.1f} s" if seconds is not None else ""
        _err(f"wrote {path}" + (f" and {data_path}" if data_path else "") + took)
    missing = [f"{name} at {p.get('tau_fm', p.get('ratio'))}"
               for name, entry in data.get("series", {}).items()
               for p in entry["points"]
               if (p.get("k_tau", 0) is None or p.get("r_blu", 0) is None)
               and not str(p.get("status", "")).startswith(SKIPPED)]
    if missing:
        _err("no optimum (gain on its bound or solver failure), left out: " + ", ".join(missing))
        raise SystemExit(EXIT_NOT_SUCCESS)
    raise SystemExit(EXIT_OK)


def _progress(quiet: bool):
    return None if quiet else _err


@contextlib.contextmanager
def _computing() -> Iterator[None]:
    """Solver chatter to stderr; Ctrl-C ends the command with status 130, nothing written."""
    try:
        with _stdout_to_stderr():
            yield
    except KeyboardInterrupt:
        _fail("interrupted; nothing written", 130)


@main.group(epilog=_CHART_EPILOG)
def chart() -> None:
    """Koren 1979's design charts (Figs 6, 8, 9), computed by tuning with feedtune.

    Each writes a plot (--out FILE.png, .svg or .pdf) and optionally the computed points
    (--data FILE.json or FILE.csv). Progress goes to stderr.
    """


_OUT = click.option("--out", "out", required=True, metavar="FILE.png",
                    help="Write the chart here; the format follows the suffix (.png, .svg, .pdf).")
_DATA = click.option("--data", "data", metavar="FILE.json|FILE.csv",
                     help="Also write the computed points (JSON: everything; CSV: one row per point).")
_QUIET = click.option("-q", "--quiet", is_flag=True, help="No progress on stderr.")
_IAE_TIME = click.option("--iae-time", type=click.Choice(["natural", "absolute"]),
                         default="natural", show_default=True,
                         help="Time of the IAE integral: natural = over ω_n·t [rad] (Koren's "
                              "convention; gives Kτ = 0.567 at T = 0), absolute = over t [s] "
                              "(no interior optimum at T = 0).")


@chart.command("loci", epilog=_CHART_EPILOG)
@_OUT
@_DATA
@click.option("--time-constant", type=_POSITIVE, default=0.02, show_default=True, metavar="S",
              help="Drive time constant τ [s]; Kτ against T/τ does not depend on it.")
@click.option("--ratio-min", type=click.FloatRange(min=0), default=0.0, show_default=True,
              metavar="T/TAU", help="First T/τ of the grid [1]; 0 is the reference-pulse loop.")
@click.option("--ratio-max", type=click.FloatRange(min=0, max=20, min_open=True), default=3.0,
              show_default=True, metavar="T/TAU", help="Last T/τ of the grid [1].")
@click.option("--points", type=click.IntRange(min=2, max=200), default=13, show_default=True,
              help="Grid points per locus [count] (≈ 0.05–0.8 s each for min IAE, less for the others).")
@_IAE_TIME
@click.option("--omega-t", type=click.FloatRange(min=0, max=0.5, min_open=True), default=0.002,
              show_default=True, metavar="RAD",
              help="ωT [rad] (ωτ at T = 0) of the circle whose radial error is minimised; "
                   "eq 40 is the limit ωT → 0.")
@_QUIET
def chart_loci(out, data, time_constant, ratio_min, ratio_max, points, iae_time, omega_t, quiet):
    """Fig 6: Kτ against T/τ for minimum IAE, minimum radial error and ζ = 0.707.

    Every point is a tuned spec for the software_servo plant; eq 40 (Kτ = 1/(T/τ + 2)) and
    the ζ = 0.707 root of eqs 17–19 are drawn dashed for comparison.
    """
    path, data_path = _chart_paths(out, data)
    _check_range(ratio_min, ratio_max, "--ratio-min", "--ratio-max")
    from feedtune.charts.koren import loci

    with _computing():
        result = loci(time_constant, ratio_min, ratio_max, points, iae_time, omega_t,
                      progress=_progress(quiet))
    _write_chart("loci", result, path, data_path, quiet)


@chart.command("min-radius", epilog=_CHART_EPILOG)
@_OUT
@_DATA
@click.option("--tau-fm-min", type=_POSITIVE, default=40.0, show_default=True, metavar="BLU",
              help="First τ·f_m of the grid [BLU] (τ [s] × f_m [pulses/s]), log-spaced.")
@click.option("--tau-fm-max", type=_POSITIVE, default=1000.0, show_default=True, metavar="BLU",
              help="Last τ·f_m of the grid [BLU]; large values make the min-IAE sampled "
                   "points slow (long step responses: ≈ 3 s at 1000).")
@click.option("--points", type=click.IntRange(min=2, max=200), default=12, show_default=True,
              help="Grid points per curve [count].")
@click.option("--encoder-ratio", type=_POSITIVE, default=100.0, show_default=True,
              metavar="FM/FS", help="T·f_m = f_m/f_s of the sampled-data curves [1] (eq 26 at its limit).")
@click.option("--time-constant", type=_POSITIVE, default=0.02, show_default=True, metavar="S",
              help="Drive time constant τ [s] of the tuned specs (r/BLU depends on τ·f_m only).")
@click.option("--blu", type=_POSITIVE, default=1e-5, show_default=True, metavar="M",
              help="Basic length unit [m] of the tuned specs (r/BLU depends on τ·f_m only).")
@_IAE_TIME
@_QUIET
def chart_min_radius(out, data, tau_fm_min, tau_fm_max, points, encoder_ratio, time_constant,
                     blu, iae_time, quiet):
    """Fig 8: minimum allowable radius r/BLU against τ·f_m for each design criterion.

    Gains are tuned (min IAE, min radial error; reference-pulse and sampled-data at
    T·f_m = --encoder-ratio); the radius is feedtune's exact min_radius at V_m = f_m·BLU
    [m/s]. Eq 34 and eq 39 (corrected to 4^(1/3), and as printed) are drawn dashed/dotted.
    """
    path, data_path = _chart_paths(out, data)
    _check_range(tau_fm_min, tau_fm_max, "--tau-fm-min", "--tau-fm-max")
    from feedtune.charts.koren import min_radius

    with _computing():
        result = min_radius(tau_fm_min, tau_fm_max, points, encoder_ratio, time_constant, blu,
                            iae_time, progress=_progress(quiet))
    _write_chart("min-radius", result, path, data_path, quiet)


@chart.command("selection", epilog=_CHART_EPILOG)
@_OUT
@_DATA
@click.option("--fm-min", type=_POSITIVE, default=1e2, show_default=True, metavar="PULSES/S",
              help="Left end of the f_m axis [pulses/s].")
@click.option("--fm-max", type=_POSITIVE, default=1e6, show_default=True, metavar="PULSES/S",
              help="Right end of the f_m axis [pulses/s].")
@click.option("--tau-min", type=_POSITIVE, default=1e-3, show_default=True, metavar="S",
              help="Bottom of the τ axis [s].")
@click.option("--tau-max", type=_POSITIVE, default=1.0, show_default=True, metavar="S",
              help="Top of the τ axis [s].")
@click.option("--execution-time", type=_POSITIVE, default=1e-4, show_default=True, metavar="S",
              help="Interpolator iteration time t_e [s]; reference-pulse needs f_m ≤ 1/t_e (eq 2).")
@click.option("--encoder-ratio", type=_POSITIVE, default=100.0, show_default=True,
              metavar="FM/FS", help="Minimum f_m/f_s [1] (eq 26).")
@click.option("--sampling-ratio", type=_POSITIVE, default=math.pi / 4, show_default="π/4",
              metavar="T/TAU", help="T/τ [1] of the sampled-data design (eq 23).")
@click.option("--time-constant", type=_POSITIVE, default=None, metavar="S",
              help="Mark a design: drive time constant τ [s] (with --blu and --max-velocity).")
@click.option("--blu", type=_POSITIVE, default=None, metavar="M",
              help="Mark a design: basic length unit [m].")
@click.option("--max-velocity", type=_POSITIVE, default=None, metavar="M/S",
              help="Mark a design: maximum axis velocity V_m [m/s]; f_m = V_m/BLU (eq 1).")
@_QUIET
def chart_selection(out, data, fm_min, fm_max, tau_min, tau_max, execution_time, encoder_ratio,
                    sampling_ratio, time_constant, blu, max_velocity, quiet):
    """Fig 9: where reference-pulse, sampled-data, either or neither applies, over f_m
    [pulses/s] and τ [s], from eq 2 (f_m ≤ 1/t_e) and eq 27 (τ·f_m ≥ (f_m/f_s)/(T/τ))."""
    path, data_path = _chart_paths(out, data)
    _check_range(fm_min, fm_max, "--fm-min", "--fm-max")
    _check_range(tau_min, tau_max, "--tau-min", "--tau-max")
    marks = {"--time-constant": time_constant, "--blu": blu, "--max-velocity": max_velocity}
    given = [name for name, value in marks.items() if value is not None]
    if given and len(given) < 3:
        missing = [name for name in marks if name not in given]
        raise click.BadParameter(f"marking a design needs {', '.join(missing)} too",
                                 param_hint=f"'{missing[0]}'")
    from feedtune.charts.koren import selection

    design = None
    if given:
        design = {"time_constant": time_constant, "pulse_rate": max_velocity / blu}
    result = selection(fm_min, fm_max, tau_min, tau_max, execution_time, encoder_ratio,
                       sampling_ratio, design)
    _write_chart("selection", result, path, data_path, quiet)


def _select_lines(rec) -> list[str]:
    names = {"reference_pulse": "reference-pulse", "sampled_data": "sampled-data"}
    lines = [f"f_m = V_m/BLU = {_g(rec.pulse_rate)} [pulses/s] (eq 1); "
             f"τ·f_m = {_g(rec.time_constant * rec.pulse_rate)} [BLU]"]
    lines.append("recommended: " + (names.get(rec.technique, "none")) + f" — {rec.reason}")
    for key, d in rec.designs.items():
        lines.append(f"{names[key]}: {'applicable' if d.applicable else 'not applicable'} — {d.reason}")
        if not d.applicable:
            continue
        if d.sampling_period is not None:
            lines.append(f"  T = {_g(d.sampling_period)} [s], f_s = {_g(d.sampling_frequency)} [Hz], "
                         f"f_m/f_s = {_g(d.encoder_ratio)} [1], T/τ = "
                         f"{_g(d.sampling_period / rec.time_constant)} [1]")
        lines.append(f"  K = {_g(d.gain)} [1/s] ({d.gain_rule}), ζ = {_g(d.damping_ratio)} [1]")
        lines.append(f"  minimum radius at V_m: {_g(d.min_radius)} [m] exact; "
                     f"{_g(d.min_radius_formula)} [m] by {d.min_radius_rule}")
    if rec.radius is not None:
        verdict = {True: "met", False: "NOT met", None: "n/a"}[rec.radius_ok]
        lines.append(f"required radius {_g(rec.radius)} [m] at V_m: {verdict}")
    lines.extend(f"note: {note}" for note in rec.notes)
    return lines


@main.command("select", epilog="Exit status: 0 a technique is recommended (and meets "
              "--radius); 1 no technique applies, or none meets --radius at V_m; 2 bad options.")
@click.option("--time-constant", type=_POSITIVE, required=True, metavar="S",
              help="Drive time constant τ [s] (Koren eq 3).")
@click.option("--blu", type=_POSITIVE, required=True, metavar="M",
              help="Basic length unit, one encoder pulse [m].")
@click.option("--max-velocity", type=_POSITIVE, required=True, metavar="M/S",
              help="Maximum axis velocity V_m [m/s]; f_m = V_m/BLU (eq 1).")
@click.option("--radius", type=_POSITIVE, default=None, metavar="M",
              help="Smallest radius the parts need at V_m [m]: checked against the minimum "
                   "allowable radius, and the circle of the emitted contouring spec.")
@click.option("--motion", type=click.Choice(["contouring", "linear"]), default="contouring",
              show_default=True,
              help="contouring: lines and circles, minimum radial error (eqs 11, 40); "
                   "linear: minimum IAE for sampled-data (Fig 6, tuned).")
@click.option("--execution-time", type=_POSITIVE, default=1e-4, show_default=True, metavar="S",
              help="Interpolator iteration time t_e [s]; reference-pulse needs f_m ≤ 1/t_e (eq 2).")
@click.option("--encoder-ratio", type=_POSITIVE, default=100.0, show_default=True,
              metavar="FM/FS", help="Minimum f_m/f_s [1] (eq 26).")
@click.option("--sampling-ratio", type=_POSITIVE, default=math.pi / 4, show_default="π/4",
              metavar="T/TAU", help="T/τ [1] of the sampled-data design (eq 23).")
@click.option("--fs-rounding", type=click.Choice(["none", "power-of-two"]), default="none",
              show_default=True,
              help="power-of-two: f_s [Hz] rounded to the nearest power of two that keeps "
                   "f_m/f_s ≥ --encoder-ratio (Koren's 62.5 → 64 Hz).")
@click.option("--emit-spec", "emit_spec", metavar="FILE",
              help="Write a spec that `feedtune tune` accepts for the recommended design "
                   "('-': stdout, the recommendation then goes to stderr).")
@click.option("--json", "as_json", is_flag=True, help="Print the recommendation as JSON.")
def select_command(time_constant, blu, max_velocity, radius, motion, execution_time,
                   encoder_ratio, sampling_ratio, fs_rounding, emit_spec, as_json):
    """Recommend reference-pulse or sampled-data as Koren 1979's Summary does, with
    K [1/s], T [s], f_s [Hz] and the minimum allowable radius [m] at V_m."""
    if emit_spec == STDIN and as_json:
        raise click.BadParameter("'-' (stdout) cannot be combined with --json; give a file",
                                 param_hint="'--emit-spec'")
    spec_path = None
    if emit_spec is not None and emit_spec != STDIN:
        spec_path = Path(emit_spec)
        if spec_path.is_dir() or not spec_path.parent.is_dir():
            raise click.BadParameter(f"{emit_spec}: not a file in an existing directory",
                                     param_hint="'--emit-spec'")
    from feedtune.charts.selection import recommend, spec_for

    with _computing():
        rec = recommend(time_constant, blu, max_velocity, radius, motion, execution_time,
                        encoder_ratio, sampling_ratio, fs_rounding)
    if as_json:
        text = json.dumps(rec.as_dict(), indent=2, ensure_ascii=False) + "\n"
        _emit(text.encode("utf-8"), None)
    else:
        echo = _err if emit_spec == STDIN else click.echo
        for line in _select_lines(rec):
            echo(line)
    if emit_spec is not None:
        if rec.technique is None:
            _fail("--emit-spec: no technique applies, so there is no spec to write",
                  EXIT_NOT_SUCCESS)
        spec = json.dumps(spec_for(rec), indent=2, ensure_ascii=False) + "\n"
        _emit(spec.encode("utf-8"), spec_path)
        if spec_path is not None:
            _err(f"wrote {spec_path}")
    ok = rec.technique is not None and rec.radius_ok is not False
    raise SystemExit(EXIT_OK if ok else EXIT_NOT_SUCCESS)


if __name__ == "__main__":  # pragma: no cover
    main()
