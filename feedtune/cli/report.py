"""``feedtune report``: plots and an HTML page of a result; the report directory checks
that ``tune --report`` shares."""

from __future__ import annotations

from pathlib import Path

import click

from feedtune.cli.common import EXIT_OK, err, fail


def check_report_dir(report_dir: str | None, option: str = "--report") -> Path | None:
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


def write_report(result, out: Path, quiet: bool) -> None:
    """Draw ``result``'s report (:meth:`feedtune.api.Result.report`) into ``out``."""
    from feedtune.report import ReportDirError

    try:
        written = result.report(out)
    except ReportDirError as exc:  # a file appeared since the check
        fail(str(exc))
    if not quiet:
        drawn = len(written.figures)
        left_out = [f"{stem} ({why})" for stem, why in written.left_out.items()]
        err(f"wrote {written.page} ({drawn} figure{'s' if drawn != 1 else ''})"
            + ("; not drawn: " + "; ".join(left_out) if left_out else ""))


@click.command(epilog="Exit status: 0 report written; 2 the result cannot be read or the "
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

    path = check_report_dir(out, "--out")
    try:
        loaded = load_result(result_file)
    except (FileNotFoundError, ResultError) as exc:
        fail(str(exc))
    write_report(loaded, path, quiet)
    raise SystemExit(EXIT_OK)
