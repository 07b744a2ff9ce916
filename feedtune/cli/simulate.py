"""``feedtune simulate``: a machine spec over its path or a part program, without tuning."""

from __future__ import annotations

import json

import click

from feedtune.cli.common import EPILOG, EXIT_OK, check_output, computing, emit, err, fail
from feedtune.cli.report import check_report_dir

#: largest part program read [bytes]
MAX_PROGRAM_BYTES = 16_000_000


def load_machine(machine: str):
    """Read and parse MACHINE, or print its errors and exit 2."""
    from feedtune.cli.common import read_spec, spec_errors, spec_label
    from feedtune.machine.spec import parse_machine
    from feedtune.schema.spec import SpecError

    try:
        return parse_machine(read_spec(machine))
    except SpecError as exc:
        spec_errors(spec_label(machine), exc.errors)


def load_path(spec, program: str | None):
    """The path: the program's (the caller's file) or the spec's built-in; exit 2 when
    neither, or when the program cannot be read or parsed (its line in the message)."""
    from feedtune.machine.gcode import ProgramError, parse_program
    from feedtune.machine.run import builtin_path

    if program is None:
        if spec.path is None:
            fail("/path: the machine spec has no path; give one or --program PART.ngc")
        return builtin_path(spec.path), None
    try:
        with open(program, "rb") as handle:
            data = handle.read(MAX_PROGRAM_BYTES + 1)
    except OSError as exc:
        fail(f"{program}: cannot read: {exc.strerror or exc}")
    if len(data) > MAX_PROGRAM_BYTES:
        fail(f"{program}: larger than {MAX_PROGRAM_BYTES} bytes")
    try:
        parsed = parse_program(data.decode("utf-8"), source=program)
    except UnicodeDecodeError as exc:
        fail(f"{program}: not UTF-8 text (byte {exc.start})")
    except ProgramError as exc:
        fail(str(exc))
    for skip in parsed.skips:
        err(f"note: {program}: line {skip.line}: {skip.word} skipped: {skip.reason}")
    return parsed.path, program


@click.command(epilog=EPILOG)
@click.argument("machine", metavar="MACHINE")
@click.option("--program", metavar="PART.ngc",
              help="A G-code part program (mm or inch; the path of the run, replacing the "
                   "spec's built-in path).")
@click.option("-o", "--output", metavar="OUT",
              help="Write the metrics JSON here (atomically) instead of stdout; '-' is stdout.")
@click.option("--report", "report_dir", metavar="DIR",
              help="Also draw the programmed and actual path (contour error magnified and "
                   "coloured) and the error against path length into DIR.")
def simulate(machine: str, program: str | None, output: str | None,
             report_dir: str | None) -> None:
    """Simulate MACHINE (a machine spec JSON, or '-') over its path or PART.ngc.

    Every axis' closed loop is simulated exactly at the sampling period [s]; the JSON
    holds the contour metrics (lengths [m], times [s]): largest and RMS contour error,
    the error at each corner, the overshoot at each stop, each axis' following error,
    the cycle time and the deceleration blocks.
    """
    target = check_output(output)
    report_path = check_report_dir(report_dir)
    spec = load_machine(machine)
    path, source = load_path(spec, program)
    from feedtune.machine.run import run
    from feedtune.machine.simulate import UnstableAxis

    with computing():
        try:
            result = run(spec, path)
        except UnstableAxis as exc:
            fail(f"{machine}: {exc}", 1)
        except ValueError as exc:
            fail(f"{source or machine}: {exc}")
    document = {"name": spec.name, "program": source, "axes": list(result.axes),
                "samples": len(result.time), "metrics": result.metrics}
    emit((json.dumps(document, indent=2) + "\n").encode("utf-8"), target)
    if report_path is not None:
        from feedtune.report.machine import write_machine_report

        for written in write_machine_report(result, report_path):
            err(f"wrote {written}")
    raise SystemExit(EXIT_OK)


def tune_machine_command(machine: str, program: str | None, target, report_path) -> None:
    """``feedtune tune MACHINE.json``: search the gains, sampling period and feed override
    (feedtune.machine.tune), write the result JSON; exit 0, or 1 when infeasible."""
    spec = load_machine(machine)
    path, _ = load_path(spec, program)
    from feedtune.machine.run import run
    from feedtune.machine.tune import MachineTuner

    with computing():
        tuner = MachineTuner(spec, path)
        document = tuner.solve()
    emit((json.dumps(document, indent=2) + "\n").encode("utf-8"), target)
    err(f"{document['status']}: max contour error "
        f"{(document['metrics'] or {}).get('max_contour_error')} m, cycle time "
        f"{(document['metrics'] or {}).get('cycle_time')} s, {document['evaluations']} "
        "simulations")
    if report_path is not None and document["metrics"] is not None:
        from feedtune.report.machine import write_machine_report

        for written in write_machine_report(run(spec, path, tuner.answer),
                                            report_path):
            err(f"wrote {written}")
    raise SystemExit(EXIT_OK if document["success"] else 1)
