"""``feedtune identify``: a plant block from measured data (issue 17)."""

from __future__ import annotations

import json

import click

from feedtune.cli.common import (EXIT_OK, POSITIVE, QUIET, check_output, emit, err, fail, fmt,
                                 internal_error)
from feedtune.cli.report import check_report_dir

MODELS = ("software_servo", "hydraulic_rotary", "ward_leonard", "linear", "frd")
#: the options that shape the linear model only
LINEAR_OPTIONS = ("poles", "zeros", "integrators", "dead_time", "max_dead_time")


def _template(path: str) -> dict:
    """The plant block of ``--like`` (a spec's "plant", or a plant block), or exit 2."""
    try:
        with open(path, "rb") as handle:
            document = json.loads(handle.read(1_000_000))
    except (OSError, ValueError) as exc:
        fail(f"{path}: cannot be read as JSON ({exc})")
    plant = document.get("plant", document) if isinstance(document, dict) else None
    if not isinstance(plant, dict) or not isinstance(plant.get("type"), str):
        fail(f"{path}: neither a spec with a \"plant\" nor a plant block with a \"type\"")
    return plant


@click.command(epilog="Exit status: 0 identified; 2 a data file cannot be used or the data "
                      "cannot determine the model (nothing written); 3 internal error.")
@click.argument("data", metavar="DATA...", nargs=-1, required=True)
@click.option("--model", "model_name", type=click.Choice(MODELS), required=True,
              help="What to fit: software_servo (velocity gain [m/(s·U)], time constant "
                   "τ [s]), hydraulic_rotary (gain [rad/(s·V)], torque-motor time constant "
                   "[s], ω_n [rad/s], ξ [1]), ward_leonard (gain [rad/(s·V)], field, "
                   "electromechanical and armature time constants [s]) or linear (a transfer "
                   "function of the orders below, coefficients in powers of s [s^i]) or frd "
                   "(no fit: the frequency responses themselves, in rad/s, as a "
                   "frequency_response_data block for the convex technique; --integrators "
                   "declares the plant's poles at s = 0).")
@click.option("-o", "--output", metavar="PLANT.json",
              help="Write the plant block (the spec's \"plant\" object) here, atomically; "
                   "the identification JSON still goes to stdout.")
@click.option("--report", "report_dir", metavar="DIR",
              help="Also write identification.html and one PNG per data set (data against "
                   "model: time [s] and output [m, rad, m/s or rad/s], or magnitude and "
                   "phase [deg] against frequency [rad/s]) into DIR.")
@click.option("--poles", type=click.IntRange(0, 12), default=1, show_default=True,
              help="linear: degree n of a(s), the poles other than at s = 0 [1].")
@click.option("--zeros", type=click.IntRange(0, 12), default=0, show_default=True,
              help="linear: degree m of b(s) [1].")
@click.option("--integrators", type=click.IntRange(0, 3), default=1, show_default=True,
              help="linear: poles k at s = 0 of the command → position response [1] (1: the "
                   "velocity follows the command; 2: the command is a torque or force).")
@click.option("--dead-time/--no-dead-time", default=False, show_default=True,
              help="linear: also fit an input dead time θ [s].")
@click.option("--max-dead-time", type=POSITIVE, metavar="SECONDS",
              help="linear with --dead-time: largest dead time searched [s]; default two turns "
                   "of phase at the highest measured frequency, or 20 samples.")
@click.option("--like", "like", metavar="SPEC.json",
              help="A spec (its \"plant\") or plant block of the same type whose other "
                   "fields the written block keeps: technique, compensators, controllers, "
                   "BLU [m], … (constants the identification replaces are left out).")
@QUIET
def identify(data, model_name, output, report_dir, poles, zeros, integrators, dead_time,
             max_dead_time, like, quiet):
    """Identify a plant from measured DATA files of one axis (CSV or JSON).

    Each file is a time series (time[s], command[U], position[m or rad] or velocity[m/s or
    rad/s]) or a frequency response (frequency[Hz or rad/s], magnitude[OUT/U] and
    phase[deg or rad], or real[OUT/U] and imag[OUT/U], optionally coherence[1]), units in
    the header row (CSV) or a "units" object (JSON). All files are fitted together with
    one set of parameters. Prints the identification as JSON: each parameter with its unit
    and standard error, the transfer function, NRMSE [1] per file, what is lumped, and the
    plant block that `feedtune tune` takes.
    """
    context = click.get_current_context()
    given = [name for name in LINEAR_OPTIONS
             if context.get_parameter_source(name) == click.core.ParameterSource.COMMANDLINE]
    if model_name == "frd" and given in ([], ["integrators"]) and report_dir is None and like is None:
        _frd(data, output, integrators, quiet)
    if given and model_name != "linear":
        raise click.UsageError(f"--{given[0].replace('_', '-')} applies to --model linear only")
    target = check_output(output)
    report_path = check_report_dir(report_dir)
    from feedtune.measured import models
    from feedtune.measured.data import DataError, read_all
    from feedtune.measured.identify import FitError, identify as run_identify

    chosen = {"software_servo": models.software_servo,
              "hydraulic_rotary": models.hydraulic_rotary,
              "ward_leonard": models.ward_leonard,
              "linear": lambda: models.linear(poles, zeros, integrators, dead_time)}
    template = _template(like) if like is not None else None
    try:
        measured = read_all(data)
        result = run_identify(measured, chosen[model_name](), max_dead_time, template)
    except DataError as exc:
        fail(str(exc))
    except FitError as exc:
        fail(f"{', '.join(data)}: {exc}")
    except KeyboardInterrupt:
        fail("interrupted; nothing written", 130)
    except Exception as exc:  # a bug: say so, keep the traceback for the report
        internal_error(exc, "the data")
    document = result.to_dict()
    text = json.dumps(document, indent=2, allow_nan=False) + "\n"
    block = json.dumps(result.plant, indent=2, allow_nan=False) + "\n"
    if report_path is not None:
        from feedtune.measured.report import ReportDirError, write_identification_report

        try:
            page = write_identification_report(result, report_path)
        except ReportDirError as exc:
            fail(str(exc))
        if not quiet:
            err(f"wrote {page}")
    if target is not None:
        emit(block.encode("utf-8"), target)
    emit(text.encode("utf-8"), None)
    if not quiet:
        for name, p in document["parameters"].items():
            err(f"{name} = {fmt(p['value'])} ± {fmt(p['standard_error'])} {p['unit']}")
        for entry in document["data"]:
            err(f"{entry['source']}: NRMSE {entry['nrmse']:.4g}")
        if target is not None:
            err(f"wrote {target}")
    raise SystemExit(EXIT_OK)


def _frd(data, output: str | None, integrators: int, quiet: bool) -> None:
    """``--model frd``: the measured frequency responses as a ``frequency_response_data``
    plant block (:func:`feedtune.measured.datadriven_spec.frd_plant_block`), written to
    ``-o`` and stdout; bad data is exit 2, nothing written."""
    target = check_output(output)
    from feedtune.measured.data import DataError, FrequencyResponseData, read_all
    from feedtune.measured.datadriven_spec import frd_plant_block

    try:
        measured = read_all(data)
    except DataError as exc:
        fail(str(exc))
    series = [d.source for d in measured if not isinstance(d, FrequencyResponseData)]
    if series:
        fail(f"{series[0]}: --model frd takes frequency responses, not a time series")
    try:
        block = frd_plant_block(measured, integrators=integrators)
    except ValueError as exc:
        fail(f"{', '.join(data)}: {exc}")
    text = (json.dumps(block, indent=1, allow_nan=False) + "\n").encode("utf-8")
    if target is not None:
        emit(text, target)
    emit(text, None)
    if not quiet:
        err(f"{len(block['sets'])} frequency response(s), "
            f"{sum(len(s['frequency']) for s in block['sets'])} points; controller "
            f"{block['controller']}: set controller, filter_time_constant [s] and the "
            "tunables in the spec" + (f"; wrote {target}" if target is not None else ""))
    raise SystemExit(EXIT_OK)
