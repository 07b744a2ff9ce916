"""``feedtune select``: reference-pulse or sampled-data, as Koren 1979's Summary recommends."""

from __future__ import annotations

import json
import math
from pathlib import Path

import click

from feedtune.cli.common import (EXIT_NOT_SUCCESS, EXIT_OK, POSITIVE, STDIN, computing, emit, err,
                                 fail, fmt)


def _select_lines(rec) -> list[str]:
    names = {"reference_pulse": "reference-pulse", "sampled_data": "sampled-data"}
    lines = [f"f_m = V_m/BLU = {fmt(rec.pulse_rate)} [pulses/s] (eq 1); "
             f"τ·f_m = {fmt(rec.time_constant * rec.pulse_rate)} [BLU]"]
    lines.append("recommended: " + (names.get(rec.technique, "none")) + f" — {rec.reason}")
    for key, d in rec.designs.items():
        lines.append(f"{names[key]}: {'applicable' if d.applicable else 'not applicable'} — {d.reason}")
        if not d.applicable:
            continue
        if d.sampling_period is not None:
            lines.append(f"  T = {fmt(d.sampling_period)} [s], f_s = {fmt(d.sampling_frequency)} [Hz], "
                         f"f_m/f_s = {fmt(d.encoder_ratio)} [1], T/τ = "
                         f"{fmt(d.sampling_period / rec.time_constant)} [1]")
        lines.append(f"  K = {fmt(d.gain)} [1/s] ({d.gain_rule}), ζ = {fmt(d.damping_ratio)} [1]")
        lines.append(f"  minimum radius at V_m: {fmt(d.min_radius)} [m] exact; "
                     f"{fmt(d.min_radius_formula)} [m] by {d.min_radius_rule}")
    if rec.radius is not None:
        verdict = {True: "met", False: "NOT met", None: "n/a"}[rec.radius_ok]
        lines.append(f"required radius {fmt(rec.radius)} [m] at V_m: {verdict}")
    lines.extend(f"note: {note}" for note in rec.notes)
    return lines


@click.command("select", epilog="Exit status: 0 a technique is recommended (and meets "
               "--radius); 1 no technique applies, or none meets --radius at V_m; 2 bad options.")
@click.option("--time-constant", type=POSITIVE, required=True, metavar="S",
              help="Drive time constant τ [s] (Koren eq 3).")
@click.option("--blu", type=POSITIVE, required=True, metavar="M",
              help="Basic length unit, one encoder pulse [m].")
@click.option("--max-velocity", type=POSITIVE, required=True, metavar="M/S",
              help="Maximum axis velocity V_m [m/s]; f_m = V_m/BLU (eq 1).")
@click.option("--radius", type=POSITIVE, default=None, metavar="M",
              help="Smallest radius the parts need at V_m [m]: checked against the minimum "
                   "allowable radius, and the circle of the emitted contouring spec.")
@click.option("--motion", type=click.Choice(["contouring", "linear"]), default="contouring",
              show_default=True,
              help="contouring: lines and circles, minimum radial error (eqs 11, 40); "
                   "linear: minimum IAE for sampled-data (Fig 6, tuned).")
@click.option("--execution-time", type=POSITIVE, default=1e-4, show_default=True, metavar="S",
              help="Interpolator iteration time t_e [s]; reference-pulse needs f_m ≤ 1/t_e (eq 2).")
@click.option("--encoder-ratio", type=POSITIVE, default=100.0, show_default=True,
              metavar="FM/FS", help="Minimum f_m/f_s [1] (eq 26).")
@click.option("--sampling-ratio", type=POSITIVE, default=math.pi / 4, show_default="π/4",
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

    with computing():
        rec = recommend(time_constant, blu, max_velocity, radius, motion, execution_time,
                        encoder_ratio, sampling_ratio, fs_rounding)
    if as_json:
        text = json.dumps(rec.as_dict(), indent=2, ensure_ascii=False) + "\n"
        emit(text.encode("utf-8"), None)
    else:
        echo = err if emit_spec == STDIN else click.echo
        for line in _select_lines(rec):
            echo(line)
    if emit_spec is not None:
        if rec.technique is None:
            fail("--emit-spec: no technique applies, so there is no spec to write",
                 EXIT_NOT_SUCCESS)
        spec = json.dumps(spec_for(rec), indent=2, ensure_ascii=False) + "\n"
        emit(spec.encode("utf-8"), spec_path)
        if spec_path is not None:
            err(f"wrote {spec_path}")
    ok = rec.technique is not None and rec.radius_ok is not False
    raise SystemExit(EXIT_OK if ok else EXIT_NOT_SUCCESS)
