"""``feedtune tune``: solve a spec, write its result JSON."""

from __future__ import annotations

import click

from feedtune.cli.common import (EPILOG, EXIT_NOT_SUCCESS, EXIT_OK, QUIET, check_output, emit,
                                 err, fail, fmt, internal_error, parse, spec_errors, spec_label,
                                 stdout_to_stderr)
from feedtune.cli.report import check_report_dir, write_report


def _report_start(start, total: int) -> None:
    """One stderr line per multistart start, so long tunings show progress."""
    err(f"start {start.index + 1}/{total}: {_start_text(start)}")


def _start_text(start) -> str:
    """What one start did, in words: a start without a stable point was never solved."""
    if start.return_status == "No_Stable_Start":
        return (f"no stable start (restoration found no stable loop near this point; not "
                f"solved), {start.solve_time:.3f} s")
    if start.return_status == "No_Free_Tunables":
        return "nothing to solve (every tunable fixed); evaluated"
    objective = "-" if start.objective is None else fmt(start.objective)
    feasible = "" if start.feasible else " but violates a constraint or stability"
    # a root search counts its evaluations of the signed e, not iterations
    unit = "evaluations of e" if start.method == "root" else "iterations"
    return (f"{start.status}{feasible}, objective {objective}, {start.iterations} {unit}, "
            f"{start.solve_time:.3f} s")


def _is_machine(spec: str) -> bool:
    """A machine spec (an object with ``axes``) rather than a tuning spec."""
    import json

    from feedtune.cli.common import read_spec

    if spec == "-":
        return False
    try:
        raw = json.loads(read_spec(spec))
    except ValueError:
        return False
    return isinstance(raw, dict) and "axes" in raw


@click.command(epilog=EPILOG)
@click.argument("spec", metavar="SPEC")
@click.option("-o", "--output", metavar="RESULT",
              help="Write the result JSON here (atomically) instead of stdout; '-' is stdout.")
@QUIET
@click.option("--report", "report_dir", metavar="DIR",
              help="Also write the report (report.html and PNG figures, as `feedtune report`) "
                   "into DIR, created if missing; checked before solving, exit 2 if DIR holds "
                   "a file of the report's names that an earlier report did not write.")
@click.option("--program", metavar="PART.ngc",
              help="A machine spec's part program (see `feedtune simulate`).")
def tune(spec: str, output: str | None, quiet: bool, report_dir: str | None,
         program: str | None) -> None:
    """Solve the tuning problem in SPEC (a JSON file, or '-' for stdin).

    The result (tuned values with their units, every metric, constraints, stability,
    IPOPT's status, provenance) is written as JSON, and nothing else, to stdout or
    RESULT. A summary for people, and anything the solver prints, goes to stderr.
    """
    from feedtune.schema.spec import SpecError

    target = check_output(output)
    report_path = check_report_dir(report_dir)
    if _is_machine(spec):
        from feedtune.cli.simulate import tune_machine_command

        tune_machine_command(spec, program, target, report_path)
    try:
        with stdout_to_stderr():
            parsed = parse(spec)
            from feedtune.api import tune as run_tune  # after parsing: slow import

            # the CLI's own process pins BLAS by its environment (feedtune.__main__)
            result = run_tune(parsed, progress=None if quiet else _report_start,
                              notify=None if quiet else err, threads=None)
    except SpecError as exc:
        spec_errors(spec_label(spec), exc.errors)
    except KeyboardInterrupt:
        fail("interrupted; no result written", 130)
    except Exception as exc:  # a bug: say so, keep the traceback for the report
        internal_error(exc, "the spec")
    # first: a closed stderr must not lose the result
    emit(result.to_json().encode("utf-8"), target)
    if not quiet:
        err(result.summary())
    if target is not None and not quiet:
        err(f"wrote {target}")
    from feedtune.validate import warning_lines

    for line in warning_lines(result.validation):  # also with --quiet: they are warnings
        err(line)
    for line in result.warnings:
        err(f"warning: implausible: {line}")
    if report_path is not None:
        write_report(result, report_path, quiet)
    raise SystemExit(EXIT_OK if result.success else EXIT_NOT_SUCCESS)
