"""Reference tests against Sato et al. (Sato et al., software servo).

Table 2's analysis values, conditions (a) and (b): a circle of r = 50 mm at ω = 1 rad/s,
K_p = 40 1/s, Δt_p = 2 ms, L = 1.5 Δt_p, N = 24 and 48 sides. The values come from the
bundled examples (examples/sato-table2-a.json, -b.json) run through the tuner with every
tunable fixed, and are checked twice: against the printed digits (tolerance justified per
test) and against an independent numpy evaluation of the paper's equations (rounding
only). Each test cites its equation; docs/errata.md explains the findings.
"""

import math

import numpy as np
import pytest

from conftest import load_example, tune_dict
from feedtune.objectives.contour.surface_roughness import table_1_coefficients

RADIUS = 0.05  # m
OMEGA = 1.0  # rad/s
GAIN = 40.0  # 1/s
PERIOD = 0.002  # s, Δt_p
DEAD_TIME = 1.5 * PERIOD  # s, L
UM = 1e-6

#: condition: (example, sides N, printed T [s], printed Δr [m], printed Δm [m])
TABLE_2 = {"a": ("sato-table2-a", 24, 0.260, 297 * UM, 383 * UM),
           "b": ("sato-table2-b", 48, 0.130, 83 * UM, 73 * UM)}


def pade_gain(omega, printed=False):
    """|G(jω)| of eq 5; ``printed``: eq 6/9 as printed, numerator ω² + (2K_p/L)²."""
    k, dead = GAIN, DEAD_TIME
    numerator = (omega**2 if printed else (k * omega) ** 2) + (2 * k / dead) ** 2
    denominator = (2 * k / dead - omega**2) ** 2 + ((2 / dead - k) * omega) ** 2
    return math.sqrt(numerator / denominator)


def delay_gain(omega):
    """|G(jω)| of eq 4 itself, the dead time e^{−Ls} not approximated."""
    open_loop = GAIN * np.exp(-1j * omega * DEAD_TIME) / (1j * omega)
    return abs(open_loop / (1 + open_loop))


def paper_values(interval, gain=pade_gain):
    """(Δr, Δm) [m] by eqs 1, 3, 7, 10 in numpy, Table 1's q = 50 row (q > 50 here)."""
    average = RADIUS * math.sqrt(math.sin(OMEGA * interval) / (OMEGA * interval))  # eq 3
    decrease = RADIUS - average * gain(OMEGA)  # eq 7
    sides = 2 * math.pi / (OMEGA * interval)  # eq 1
    sagitta = RADIUS * (1 - math.cos(OMEGA * interval / 2))
    roughness = sagitta * (0.846 * gain(sides * OMEGA) + 0.209 * gain(2 * sides * OMEGA))  # eq 10
    return decrease, roughness


@pytest.fixture(scope="module", params=sorted(TABLE_2))
def condition(request, tuned_example):
    name, sides, printed_interval, decrease, roughness = TABLE_2[request.param]
    return tuned_example(name), sides, printed_interval, decrease, roughness


def test_examples_are_table2_conditions(condition):
    """The examples hold the paper's conditions: K_p, Δt_p fixed, T = 2π/(Nω) (see
    test_table2_needs_whole_sides), q = T/Δt_p beyond Table 1 (130.9 and 65.4)."""
    result, sides, printed_interval, _, _ = condition
    assert result.success
    tuned = {name: value.value for name, value in result.tuned.items()}
    assert all(value.fixed for value in result.tuned.values())
    assert tuned["position_gain"] == GAIN and tuned["sampling_period"] == PERIOD
    assert tuned["reference_interval"] == pytest.approx(2 * math.pi / (sides * OMEGA), rel=1e-15)
    # the printed T is the interval rounded to 10 ms
    assert tuned["reference_interval"] == pytest.approx(printed_interval, abs=0.005)
    assert tuned["reference_interval"] / PERIOD > 50


def test_table2_decrease_in_radius_eq7(condition):
    """Table 2, analysis: Δr = 297 µm (a) and 83 µm (b), printed to the µm. Tolerance: half a
    unit of the printed digit, 0.5 µm — the paper's numbers are reproduced to their last
    digit (297.22 and 83.24 µm). Against numpy eqs 3, 6, 7: rounding only, 1e-9."""
    result, _, _, printed, _ = condition
    value = result.metrics["radius_decrease"].value
    assert value == pytest.approx(printed, abs=0.5 * UM)
    interval = result.tuned["reference_interval"].value
    assert value == pytest.approx(paper_values(interval)[0], rel=1e-9)


def test_table2_surface_roughness_eq10(condition):
    """Table 2, analysis: Δm = 383 µm (a) and 73 µm (b). Eq 10 with Table 1's q = 50 row
    gives 382.40 and 72.18 µm. Tolerance 1 µm: half a unit of the printed digit (0.5 µm),
    plus Table 1's own rounding (±0.0005 per coefficient: ±0.34 µm at (a), ±0.06 µm at
    (b)), plus what is left at (b), 0.26 µm beyond both, which no reading of eqs 9–10 we
    tried explains (docs/errata.md). Against numpy eqs 1, 6, 9, 10: rounding only, 1e-9."""
    result, _, _, _, printed = condition
    value = result.metrics["surface_roughness"].value
    assert value == pytest.approx(printed, abs=1 * UM)
    interval = result.tuned["reference_interval"].value
    assert value == pytest.approx(paper_values(interval)[1], rel=1e-9)


def test_table2_average_radius_eq3(condition):
    """Eq 3 with θ = 2π/N: r̄ = r·√(N sin(2π/N)/(2π)); rounding only."""
    result, sides, _, _, _ = condition
    expected = RADIUS * math.sqrt(sides * math.sin(2 * math.pi / sides) / (2 * math.pi))
    assert result.metrics["average_radius"].value == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("key", sorted(TABLE_2))
def test_table2_needs_whole_sides(key):
    """Errata: at the printed T = 260 and 130 ms (ωT = 0.26, N = 24.17 and 48.33) eqs 3 and
    7 give Δr = 293.31 and 82.26 µm, 3.7 and 0.7 µm off the printed 297 and 83 — far
    more than rounding; with N = 24 and 48 exactly the printed digits come out."""
    name, _, printed_interval, printed_decrease, printed_roughness = TABLE_2[key]
    spec = load_example(name)
    spec["tunables"]["reference_interval"] = {"value": printed_interval}
    result = tune_dict(spec)
    decrease = result.metrics["radius_decrease"].value
    assert decrease == pytest.approx(paper_values(printed_interval)[0], rel=1e-9)
    assert abs(decrease - printed_decrease) > 0.6 * UM
    assert abs(result.metrics["surface_roughness"].value - printed_roughness) > 1.5 * UM


@pytest.mark.parametrize("key", sorted(TABLE_2))
def test_table2_printed_eq6_and_exact_dead_time(key):
    """Eqs 6/9 as printed (numerator ω² + (2K_p/L)², dimensionally inconsistent) change Δr by
    0.06 µm but move Δm away from the paper: 382.03 and 71.92 µm against 382.40 and 72.18
    with K_p²ω² (printed 383, 73). The Padé model itself costs nothing here: the exact
    dead time e^{−Ls} (eq 4) gives the same Δr and Δm to 0.05 µm."""
    name, sides, _, _, printed_roughness = TABLE_2[key]
    interval = 2 * math.pi / (sides * OMEGA)
    decrease, roughness = paper_values(interval)
    printed_decrease, printed_form = paper_values(interval, lambda w: pade_gain(w, printed=True))
    assert abs(printed_decrease - decrease) < 0.1 * UM
    assert abs(printed_form - printed_roughness) > abs(roughness - printed_roughness)
    exact_decrease, exact_roughness = paper_values(interval, delay_gain)
    assert exact_decrease == pytest.approx(decrease, abs=0.05 * UM)
    assert exact_roughness == pytest.approx(roughness, abs=0.05 * UM)


@pytest.mark.parametrize("key", sorted(TABLE_2))
def test_exact_sampled_loop_gives_table2_too(key):
    """model "exact" (the sampled loop with its one-sample delay, discretised exactly)
    against the Padé model the paper uses: L = 3 ms is far below 1/ω and 1/(Nω), so both
    agree to 0.01 µm (Δr) and 0.05 µm (Δm) — well inside the printed digits."""
    name = TABLE_2[key][0]
    spec = load_example(name)
    pade = tune_dict(spec)
    spec["plant"]["model"] = "exact"
    exact = tune_dict(spec)
    for metric, tolerance in (("radius_decrease", 0.01 * UM), ("surface_roughness", 0.05 * UM)):
        assert exact.metrics[metric].value == pytest.approx(pade.metrics[metric].value,
                                                            abs=tolerance)


def _chord_ripple_peak_to_peak(steps: int | None, harmonics: int = 2) -> np.ndarray:
    """Peak-to-peak amplitude of harmonics 1..``harmonics`` of the radial ripple of a chord
    (N = 24) traversed at constant speed, per unit sagitta; ``steps``: held at q steps."""
    half = math.pi / 24  # θ/2
    u = np.arange(4096) / 4096  # fraction of the chord covered, one reference interval
    if steps is not None:
        u = np.floor(u * steps) / steps
    radius = np.hypot(math.cos(half), math.sin(half) * (2 * u - 1))  # of the point, r = 1
    ripple = (1 - radius) / (1 - math.cos(half))
    spectrum = np.fft.rfft(ripple) / len(u)
    return 4 * np.abs(spectrum[1:harmonics + 1])


def test_table1_rows_as_printed():
    """Table 1 could not be recomputed from the text (docs/errata.md): its q = 2 row is the
    square wave (4/π, 4/(3π), 4/(5π) peak-to-peak = 1.273, 0.424, 0.255 against 1.270,
    0.419, 0.247), but a chord traversed at constant speed (q → ∞) has 0.811 and 0.202
    (N = 24; the parabolic arch's 8/π² and 2/π² to 0.3 %), where the q = 50 row has 0.846
    and 0.209, 4.3 % and 3.5 % more. feedtune uses the table as printed; these numbers pin
    both facts."""
    rows = {2: [1.270, 0.0, 0.419, 0.0, 0.247], 50: [0.846, 0.209, 0.0, 0.0, 0.0]}
    for q, row in rows.items():
        assert [float(c) for c in table_1_coefficients(q)] == pytest.approx(row, abs=1e-12)
    square = _chord_ripple_peak_to_peak(2, harmonics=5)
    np.testing.assert_allclose(square, [4 / math.pi, 0, 4 / (3 * math.pi), 0, 4 / (5 * math.pi)],
                               atol=2e-3)
    chord = _chord_ripple_peak_to_peak(None)
    np.testing.assert_allclose(chord, [8 / math.pi**2, 2 / math.pi**2], rtol=5e-3)
    assert 0.846 / chord[0] - 1 == pytest.approx(0.043, abs=0.001)
    assert 0.209 / chord[1] - 1 == pytest.approx(0.035, abs=0.001)


#: exact circle test of the sampled loop at Table 2's conditions [m]: (mean radius
#: decrease −circle_mean_deviation, circle_roughness = circularity); Table 2's experiment
EXACT_TABLE_2 = {"a": (296.75 * UM, 330.98 * UM), "b": (83.23 * UM, 61.92 * UM)}
EXPERIMENT_TABLE_2 = {"a": (262 * UM, 343 * UM), "b": (80 * UM, 70 * UM)}


@pytest.mark.parametrize("key", sorted(TABLE_2))
def test_exact_circle_test_at_table2(key):
    """The exact circle test (model exact; the result reports it on the spec's circle):
    the mean radius falls short of r by Δr to 0.5 µm (eq 3's area radius against the
    time mean), while the ripple's peak-to-valley is 13.5 % (a) and 14.3 % (b) below eq 10's
    Δm — the phase-free sum of harmonics is an upper bound, as §4.2 says of (a), where
    the exact 331 µm lies nearer the measured 343 µm than the formula's 382 µm. Pinned to
    0.05 µm: exact for the ideal drive (straight between samples) at q = 1309/10 and
    720/11, the fractions the test takes for q = 130.8997 and 65.4498 (T within 0.6 and
    9.5 µs; fractions with b ≤ 256 move the values by 0.012 µm at most)."""
    name = TABLE_2[key][0]
    spec = load_example(name)
    spec["plant"]["model"] = "exact"
    result = tune_dict(spec)
    metrics = {name: value.value for name, value in result.metrics.items()}
    decrease, roughness = EXACT_TABLE_2[key]
    assert -metrics["circle_mean_deviation"] == pytest.approx(decrease, abs=0.05 * UM)
    assert -metrics["circle_mean_deviation"] == pytest.approx(metrics["radius_decrease"],
                                                              abs=0.5 * UM)
    assert metrics["circle_roughness"] == pytest.approx(roughness, abs=0.05 * UM)
    assert metrics["circularity"] == pytest.approx(roughness, abs=0.05 * UM)
    assert metrics["circle_roughness"] < 0.9 * metrics["surface_roughness"]
    if key == "a":
        measured = EXPERIMENT_TABLE_2[key][1]
        assert (abs(metrics["circle_roughness"] - measured)
                < abs(metrics["surface_roughness"] - measured))


def test_finish_and_throughput_examples(tuned_example):
    """The bundled tuning examples (docs/sato.md): finish — T and Δt_p at their minimums
    (10 and 2 ms), K_p = 43.84 s⁻¹ where Δr ≤ 10 µm binds, Δm = 0.0645 µm; throughput — the
    largest T = 26.31 ms (K_p = 49.66 s⁻¹) with Δr ≤ 10 µm and Δm ≤ 1 µm both binding. Both
    report the exact circle test beside the formulas."""
    finish = tuned_example("sato-finish")
    assert finish.success
    assert finish.tuned["sampling_period"].at_bound == "min"
    assert finish.tuned["reference_interval"].at_bound == "min"
    assert finish.tuned["position_gain"].value == pytest.approx(43.84, rel=1e-3)
    assert finish.metrics["radius_decrease"].value == pytest.approx(10 * UM, rel=1e-6)
    assert finish.metrics["surface_roughness"].value == pytest.approx(0.0645 * UM, rel=1e-3)
    assert finish.metrics["circle_roughness"].value == pytest.approx(0.0634 * UM, rel=1e-3)
    throughput = tuned_example("sato-throughput")
    assert throughput.success
    assert throughput.tuned["reference_interval"].value == pytest.approx(0.02631, rel=1e-3)
    assert throughput.tuned["position_gain"].value == pytest.approx(49.66, rel=1e-3)
    assert throughput.metrics["circle_roughness"].value == pytest.approx(0.870 * UM, rel=1e-3)
    assert throughput.metrics["circle_mean_deviation"].value == pytest.approx(-10.016 * UM,
                                                                              rel=1e-3)
