"""``feedtune chart``: Koren 1979's design charts (Figs 6, 8, 9), computed by tuning."""

from __future__ import annotations

import math
from pathlib import Path

import click

from feedtune.cli.common import EXIT_NOT_SUCCESS, EXIT_OK, POSITIVE, computing, emit, err


_CHART_EPILOG = ("Exit status: 0 chart written; 1 some points had no optimum (the chart is "
                 "still written, without them); 2 an option or output path cannot be used.")

_CHART_FORMATS = (".png", ".svg", ".pdf")


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
    from feedtune.schema.status import SKIPPED

    buffer = io.BytesIO()  # drawn in memory, then written atomically
    PLOTS[kind](data, buffer, path.suffix.lstrip(".").lower())
    emit(buffer.getvalue(), path)
    if data_path is not None:
        emit(write_data(data, data_path), data_path)
    if not quiet:
        seconds = data.get("seconds")
        took = f" in {seconds:.1f} s" if seconds is not None else ""
        err(f"wrote {path}" + (f" and {data_path}" if data_path else "") + took)
    missing = [f"{name} at {p.get('tau_fm', p.get('ratio'))}"
               for name, entry in data.get("series", {}).items()
               for p in entry["points"]
               if (p.get("k_tau", 0) is None or p.get("r_blu", 0) is None)
               and not str(p.get("status", "")).startswith(SKIPPED)]
    if missing:
        err("no optimum (gain on its bound or solver failure), left out: " + ", ".join(missing))
        raise SystemExit(EXIT_NOT_SUCCESS)
    raise SystemExit(EXIT_OK)


def _progress(quiet: bool):
    return None if quiet else err


@click.group(epilog=_CHART_EPILOG)
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
@click.option("--time-constant", type=POSITIVE, default=0.02, show_default=True, metavar="S",
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

    with computing():
        result = loci(time_constant, ratio_min, ratio_max, points, iae_time, omega_t,
                      progress=_progress(quiet))
    _write_chart("loci", result, path, data_path, quiet)


@chart.command("min-radius", epilog=_CHART_EPILOG)
@_OUT
@_DATA
@click.option("--tau-fm-min", type=POSITIVE, default=40.0, show_default=True, metavar="BLU",
              help="First τ·f_m of the grid [BLU] (τ [s] × f_m [pulses/s]), log-spaced.")
@click.option("--tau-fm-max", type=POSITIVE, default=1000.0, show_default=True, metavar="BLU",
              help="Last τ·f_m of the grid [BLU]; large values make the min-IAE sampled "
                   "points slow (long step responses: ≈ 3 s at 1000).")
@click.option("--points", type=click.IntRange(min=2, max=200), default=12, show_default=True,
              help="Grid points per curve [count].")
@click.option("--encoder-ratio", type=POSITIVE, default=100.0, show_default=True,
              metavar="FM/FS", help="T·f_m = f_m/f_s of the sampled-data curves [1] (eq 26 at its limit).")
@click.option("--time-constant", type=POSITIVE, default=0.02, show_default=True, metavar="S",
              help="Drive time constant τ [s] of the tuned specs (r/BLU depends on τ·f_m only).")
@click.option("--blu", type=POSITIVE, default=1e-5, show_default=True, metavar="M",
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

    with computing():
        result = min_radius(tau_fm_min, tau_fm_max, points, encoder_ratio, time_constant, blu,
                            iae_time, progress=_progress(quiet))
    _write_chart("min-radius", result, path, data_path, quiet)


@chart.command("selection", epilog=_CHART_EPILOG)
@_OUT
@_DATA
@click.option("--fm-min", type=POSITIVE, default=1e2, show_default=True, metavar="PULSES/S",
              help="Left end of the f_m axis [pulses/s].")
@click.option("--fm-max", type=POSITIVE, default=1e6, show_default=True, metavar="PULSES/S",
              help="Right end of the f_m axis [pulses/s].")
@click.option("--tau-min", type=POSITIVE, default=1e-3, show_default=True, metavar="S",
              help="Bottom of the τ axis [s].")
@click.option("--tau-max", type=POSITIVE, default=1.0, show_default=True, metavar="S",
              help="Top of the τ axis [s].")
@click.option("--execution-time", type=POSITIVE, default=1e-4, show_default=True, metavar="S",
              help="Interpolator iteration time t_e [s]; reference-pulse needs f_m ≤ 1/t_e (eq 2).")
@click.option("--encoder-ratio", type=POSITIVE, default=100.0, show_default=True,
              metavar="FM/FS", help="Minimum f_m/f_s [1] (eq 26).")
@click.option("--sampling-ratio", type=POSITIVE, default=math.pi / 4, show_default="π/4",
              metavar="T/TAU", help="T/τ [1] of the sampled-data design (eq 23).")
@click.option("--time-constant", type=POSITIVE, default=None, metavar="S",
              help="Mark a design: drive time constant τ [s] (with --blu and --max-velocity).")
@click.option("--blu", type=POSITIVE, default=None, metavar="M",
              help="Mark a design: basic length unit [m].")
@click.option("--max-velocity", type=POSITIVE, default=None, metavar="M/S",
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
