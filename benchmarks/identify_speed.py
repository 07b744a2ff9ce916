#!/usr/bin/env python
"""``feedtune identify``'s fit against scipy.optimize.least_squares alone, side by side.

Issue 17's speed targets on Bhatia's hydraulic drive (velocity per volt
K/((1 + τ_r s)(s²/ω_n² + 2ξs/ω_n + 1)), 4 parameters), and a harder third, all with 1 %
noise:

1. a frequency response of 1 000 points, 1–1000 rad/s (position per volt);
2. a time series of 100 000 samples at 1 kHz (velocity, random ±1 V steps held 20 ms);
3. the two-mass axis of examples/user-defined-drive.json (a 276 Hz mode over an
   anti-resonance, 0.2 ms dead time; ``linear`` with 2 poles, 2 zeros, 2 integrators and
   the dead time: 6 parameters), 1 000 points, 5 Hz–2 kHz;
4. the same axis with a 0.5 ms dead time (6.3 rad of phase at 2 kHz).

feedtune: :func:`feedtune.measured.identify.identify` (cvxpy Levy/Sanathanan–Koerner or
state-variable-filter equation error, then output-error least_squares). Baseline: the same
output-error least_squares from a neutral start (all poles at the band's geometric centre
ω0, the gain that fits best with them), what one would write without the convex stage.
Printed per problem: CPU [s] (time.process_time) and wall [s], best of --repeats, the
ratio baseline/feedtune, NRMSE [1] reached and the largest parameter error in units of
feedtune's standard errors; and the load average. One BLAS thread, as the CLI runs.

Usage::

    .venv/bin/python benchmarks/identify_speed.py [--repeats 3]
"""

from __future__ import annotations

import os

for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")  # as feedtune.__main__ does

import argparse  # noqa: E402
import time  # noqa: E402
from math import comb  # noqa: E402

import numpy as np  # noqa: E402

from feedtune.measured import models  # noqa: E402
from feedtune.measured.data import FrequencyResponseData, TimeSeriesData  # noqa: E402
from feedtune.measured.fit import band, model_output, output_error_fit  # noqa: E402
from feedtune.measured.identify import identify  # noqa: E402
from feedtune.measured.rational import Rational  # noqa: E402

SEED = 17
# Bhatia's drive: K = K_s K_q/D_m = 10 rad/(s·V), 1/ω_r = 0.01 s, ω_n = 75 rad/s, ξ = 0.5
HYDRAULIC = Rational(np.array([10.0]), np.polynomial.polynomial.polymul(
    [1, 0.01], [1, 2 * 0.5 / 75, 1 / 75 ** 2]), 1)
# the two-mass axis: P(s) = (0.002 s² + 0.0462 s + 2000)/(2e-6 s⁴ + 1.386e-4 s³ + 6 s²)
TWO_MASS = Rational(np.array([2000.0, 0.0462, 0.002]) / 6, np.array([1.0, 1.386e-4 / 6,
                                                                   2e-6 / 6]), 2, 2e-4)


def frequency_data(truth, omega, rng):
    g = truth.response(omega)
    g = g + 0.01 * np.abs(g) * (rng.standard_normal(len(g)) + 1j * rng.standard_normal(len(g))) \
        / np.sqrt(2)
    return FrequencyResponseData(omega, g, None, input_unit="V", output_unit="rad", source="frf")


def problems(rng) -> dict:
    """{label: (data, model, true named parameters)}."""
    period, count = 1e-3, 100_000
    u = np.repeat(rng.choice([-1.0, 1.0], count // 20), 20)
    y = HYDRAULIC.simulate(u, period, 1)
    y = y + 0.01 * np.sqrt(np.mean(y ** 2)) * rng.standard_normal(count)
    hydraulic, linear = models.hydraulic_rotary(), models.linear(2, 2, 2, True)
    two_mass_band = np.logspace(np.log10(2 * np.pi * 5), np.log10(2 * np.pi * 2000), 1000)
    slow = Rational(TWO_MASS.numerator, TWO_MASS.denominator, 2, 5e-4)
    truth_h = hydraulic.values(HYDRAULIC.numerator, HYDRAULIC.denominator, 0.0)
    truth_l = linear.values(TWO_MASS.numerator, TWO_MASS.denominator, TWO_MASS.dead_time)
    return {
        "hydraulic FRF, 1000 pts": (frequency_data(HYDRAULIC, np.logspace(0, 3, 1000), rng),
                                    hydraulic, truth_h),
        "hydraulic time, 100 000": (TimeSeriesData(np.arange(count) * period, u, y, input_unit="V",
                                                   output_unit="rad/s", source="time"),
                                    hydraulic, truth_h),
        "two-mass FRF, 1000 pts": (frequency_data(TWO_MASS, two_mass_band, rng), linear,
                                   truth_l),
        "two-mass, θ = 0.5 ms": (frequency_data(slow, two_mass_band, rng), linear,
                                 linear.values(slow.numerator, slow.denominator, 5e-4))}


def baseline(data, model):
    """least_squares on the output error from all poles at ω0, no zeros (b_j = 0, j ≥ 1),
    no dead time, and the gain b_0 that fits best with them."""
    structure = model.structure
    lo, hi = band([data])
    omega0 = float(np.sqrt(lo * hi))
    n, m = structure.poles, structure.zeros
    x = np.array([comb(n, i) for i in range(1, n + 1)] + [1.0] + [0.0] * m
                 + ([0.0] if structure.dead_time else []))
    unit = model_output(structure.rational(x, omega0), data, 0.0)  # linear in b_0
    target = data.response if isinstance(data, FrequencyResponseData) else data.output
    x[n] = max(np.real(np.vdot(unit, target)) / np.real(np.vdot(unit, unit)), 1e-12)
    return output_error_fit([data], structure, omega0, x, 0)


def timed(function, repeats):
    best = None
    for _ in range(repeats):
        wall, cpu = time.perf_counter(), time.process_time()
        out = function()
        cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
        best = (cpu, wall, out) if best is None or cpu < best[0] else best
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3, help="runs of each [count]")
    args = parser.parse_args()
    data = problems(np.random.default_rng(SEED))
    for d, model, _ in data.values():  # warm-up: imports, cvxpy's compiled problems
        identify([d], model)
    print(f"{'problem':24s} {'method':26s} {'CPU s':>7s} {'wall s':>7s} {'NRMSE':>8s} "
          f"{'max |err|/σ':>11s}")
    for label, (d, model, truth) in data.items():
        cpu_f, wall_f, ident = timed(lambda: identify([d], model), args.repeats)
        sigma = np.array(list(ident.standard_errors.values()))
        error_f = np.max(np.abs(np.array(list(ident.values.values())) - truth) / sigma)
        cpu_b, wall_b, fit_b = timed(lambda: baseline(d, model), args.repeats)
        b = fit_b.model
        values_b = model.values(b.numerator, b.denominator, b.dead_time)
        error_b = np.max(np.abs(values_b - truth) / sigma)
        print(f"{label:24s} {'feedtune (cvxpy + OE)':26s} {cpu_f:7.3f} {wall_f:7.3f} "
              f"{ident.fit.nrmse[0]:8.5f} {error_f:11.2f}")
        print(f"{'':24s} {'least_squares alone':26s} {cpu_b:7.3f} {wall_b:7.3f} "
              f"{fit_b.nrmse[0]:8.5f} {error_b:11.2f}")
        print(f"{'':24s} {'ratio baseline/feedtune':26s} {cpu_b / cpu_f:7.2f} "
              f"{wall_b / wall_f:7.2f}")
    print(f"load average {os.getloadavg()[0]:.2f} (1 min), {os.cpu_count()} cores")


if __name__ == "__main__":
    main()
