"""Pieces of the report: which reported value a figure marks, the Bode range, and the page
of a result with nothing to draw (a failed tuning still gets its page)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg

from feedtune.report import _png, build_figures, write_report
from feedtune.report.figures import bode_figure, bode_range, characteristic_frequencies, metric
from feedtune.validate.models import model_for
from feedtune.validate.software_servo import ServoModel

DATA = Path(__file__).resolve().parents[1] / "data"


def test_metric_picks_the_entry_whose_options_match():
    result = {"metrics": {
        "iae": {"metric": "iae", "value": 1.0, "options": {"input": "step", "time": "absolute"}},
        "iae(ramp)": {"metric": "iae", "value": 2.0, "options": {"input": "ramp", "time": "absolute"}},
        "x": {"metric": "overshoot", "value": None, "options": {}}}}
    assert metric(result, "iae", input="ramp") == 2.0
    assert metric(result, "iae", input="step", time="absolute") == 1.0
    assert metric(result, "overshoot") is None and metric(result, "m_peak") is None


def test_a_figure_is_laid_out_and_saved_by_one_renderer():
    """Each figure is on an Agg canvas of its own: its ``tight_layout`` and the PNG the
    report saves draw with one renderer, so the tick labels measured (and the log axes'
    mathtext parsed) for the layout are not measured again for the PNG. A Figure without
    a canvas lays out and saves on two fresh renderers."""
    result = json.loads((DATA / "bhatia-1971-hydraulic.result.json").read_text())
    tuned = {name: t["value"] for name, t in result["tuned"].items()}
    figure = bode_figure(model_for(result["spec"]["plant"], tuned, result["stability"]), result)
    assert isinstance(figure.canvas, FigureCanvasAgg)
    laid_out = figure.canvas.get_renderer()
    assert _png(figure).startswith(b"\x89PNG")
    assert figure.canvas.get_renderer() is laid_out


def test_a_sampled_bode_ends_at_the_nyquist_frequency():
    low, high = bode_range(ServoModel(18.0, 0.02, 0.015625))
    assert high == pytest.approx(math.pi / 0.015625, rel=1e-5) and low < high / 100


@pytest.fixture
def without_layout(monkeypatch):
    """Bode figures drawn without their final ``tight_layout``, which moves the axes on the
    canvas by measuring every text and never the arrows' data coordinates these tests read
    (as tests/unit/test_report_margins.py); the laid-out figure is
    :func:`test_a_figure_is_laid_out_and_saved_by_one_renderer`'s."""
    from matplotlib.figure import Figure

    monkeypatch.setattr(Figure, "tight_layout", lambda self, *args, **kwargs: None)


def _arrows(figure) -> dict[str, tuple]:
    """Label → (head (ω, value), tail (ω, value)) of the margin arrows on a Bode figure."""
    arrows, labels = [], {}
    for ax in figure.axes:
        for text in ax.texts:
            if text.get_text() in ("GM", "PM"):
                labels[text.get_text()] = text.xy[0]
            elif getattr(text, "arrow_patch", None) is not None:
                arrows.append((tuple(text.xy), tuple(text.xyann)))
    return {label: next(a for a in arrows if a[0][0] == w) for label, w in labels.items()}


def _margins_result(gm, pm, crossover) -> dict:
    return {"metrics": {name: {"metric": name, "value": v, "options": {}} for name, v in
                        (("gain_margin", gm), ("phase_margin", pm),
                         ("crossover_frequency", crossover))}}


@pytest.mark.parametrize("gain, tau, period, delay", [(40.0, 0.02, 0.005, 1),
                                                      (18.0, 0.02, 1 / 64, 0)])
def test_a_sampled_bode_draws_its_margins_where_python_control_finds_them(gain, tau, period,
                                                                          delay, without_layout):
    """The GM arrow rises from −GM dB to 0 dB at the phase crossover, the PM arrow from
    −180° to −180° + PM at the gain crossover; python-control (c2d ZOH, margin) places
    both crossovers (1e-9 relative: Brent on both sides)."""
    import control

    drive = control.tf([gain], [tau, 1.0, 0.0])
    open_loop = (control.sample_system(drive, period, method="zoh")
                 * control.tf([1.0], [1.0] + [0.0] * delay, period))
    gm, pm, wg, wc = control.margin(open_loop)
    figure = bode_figure(ServoModel(gain, tau, period, delay), _margins_result(gm, pm, wc))
    arrows = _arrows(figure)
    (head_w, head), (tail_w, tail) = arrows["GM"]
    assert head_w == tail_w == pytest.approx(wg, rel=1e-9)
    assert (head, tail) == pytest.approx((0.0, -20 * math.log10(gm)), abs=1e-12)
    (head_w, head), (tail_w, tail) = arrows["PM"]
    assert head_w == tail_w == pytest.approx(wc, rel=1e-9)
    assert (head, tail) == pytest.approx((-180.0 + pm, -180.0), abs=1e-12)


def test_a_gain_margin_at_the_nyquist_frequency_is_marked_there(without_layout):
    """K/s behind a ZOH: the phase reaches −180° at π/T (GM = 2/(KT)); the arrow stands at
    the Bode plot's end, π/T."""
    gain, period = 30.0, 0.01
    figure = bode_figure(ServoModel(gain, None, period),
                         _margins_result(2 / (gain * period), 60.0, None))
    (head_w, _), (_, tail) = _arrows(figure)["GM"]
    assert head_w == pytest.approx(math.pi / period, rel=1e-5)
    assert tail == pytest.approx(-20 * math.log10(2 / (gain * period)), abs=1e-12)


def test_the_bode_range_is_a_decade_around_the_loops_own_frequencies():
    """K/(s(1 + sτ)), K = 18 1/s, τ = 0.02 s: poles −25 ± 16.6j (|p| = ω_n = 30 rad/s),
    crossover ω_c² = (√(1 + 4τ²K²) − 1)/(2τ²), bandwidth ω_n √(1 − 2ζ² + √(4ζ⁴ − 4ζ² + 2))
    with ζ = 1/(2√(Kτ)): from ω_c/10 to ω_n·10."""
    k, tau = 18.0, 0.02
    crossover = math.sqrt((math.sqrt(1 + 4 * tau**2 * k**2) - 1) / (2 * tau**2))
    wn, zeta = math.sqrt(k / tau), 1 / (2 * math.sqrt(k * tau))
    bandwidth = wn * math.sqrt(1 - 2 * zeta**2 + math.sqrt(4 * zeta**4 - 4 * zeta**2 + 2))
    freqs = characteristic_frequencies(ServoModel(k, tau))
    assert freqs == pytest.approx({"slowest pole": 30.0, "dominant pole": 30.0,
                                   "crossover": crossover, "bandwidth": bandwidth}, rel=1e-9)
    assert bode_range(ServoModel(k, tau)) == pytest.approx((crossover / 10, 300.0), rel=1e-9)


def test_the_bode_range_of_bhatias_loop_ignores_its_fast_hydraulic_pole():
    """Bhatia's tuned loop: poles at −4.5e5 and −1.2e4 1/s, a bandwidth of 689.8 rad/s and
    resonances near 205 and 642 rad/s (|H| = M_peak = 1.3 at both): the diagram must show
    the band where |H| falls, not run to 1e7 rad/s, where the old range (30 × the fastest
    pole) ended."""
    result = json.loads((DATA / "bhatia-1971-hydraulic.result.json").read_text())
    model = model_for(result["spec"]["plant"],
                      {name: t["value"] for name, t in result["tuned"].items()},
                      result["stability"])
    low, high = bode_range(model)
    assert high < 1e4 < 12_076 < 454_835  # below both fast real poles
    light = max(abs(im) for _, im in result["stability"]["poles"])  # 641.7 rad/s
    bandwidth = result["metrics"]["bandwidth"]["value"]
    assert low < 10.9 and 3 * bandwidth < high and low < light < high
    omega = np.logspace(math.log10(low), math.log10(high), 2000)
    peak = np.max(np.abs(model.frequency_response(omega)[1]))
    assert peak == pytest.approx(result["metrics"]["m_peak"]["value"], rel=1e-4)


def test_a_failed_tuning_gets_a_page_saying_what_is_missing(tmp_path):
    result = json.loads((DATA / "tian-vf-pulse.result.json").read_text())
    result.update(success=False, status="solver_failed", tuned={})
    figures = build_figures(result)
    assert all(png is None and why == "nothing was tuned" for _, _, png, why in figures)
    written = write_report(result, tmp_path)
    assert written == [tmp_path / "report.html"]
    page = written[0].read_text()
    assert "solver_failed" in page and page.count("Not drawn: nothing was tuned") == len(figures)


def test_text_from_the_result_is_escaped(tmp_path):
    result = json.loads((DATA / "tian-vf-pulse.result.json").read_text())
    result["name"] = "<script>alert(1)</script>"
    result["spec"]["description"] = "</pre><script>alert(2)</script>"
    result["spec"]["plant"]["type"] = "<b>x</b>"
    page = write_report(result, tmp_path)[0].read_text()
    assert "<script>" not in page and "<b>x" not in page
    assert "&lt;script&gt;alert(1)" in page and "&lt;/pre&gt;&lt;script&gt;alert(2)" in page


def test_a_report_killed_while_writing_leaves_files_the_next_one_may_replace(tmp_path,
                                                                            monkeypatch):
    """The manifest lists old and new digests while files are replaced: after a failure
    between two files the directory holds only listed files, and a rerun completes."""
    from feedtune.report import output

    result = json.loads((DATA / "tian-vf-pulse.result.json").read_text())
    figures = build_figures(result)
    write_report(result, tmp_path, figures)
    result["name"] = "renamed"  # a different page: report.html must be replaced
    real, calls = output.write_atomic, []

    def dies_on_the_second_file(path, data):
        calls.append(path.name)
        if len(calls) == 3:  # pending manifest, first file, then the kill
            raise KeyboardInterrupt
        real(path, data)

    monkeypatch.setattr(output, "write_atomic", dies_on_the_second_file)
    with pytest.raises(KeyboardInterrupt):
        write_report(result, tmp_path, figures)
    assert calls[0] == output.MANIFEST
    monkeypatch.setattr(output, "write_atomic", real)
    written = write_report(result, tmp_path, figures)
    assert "renamed" in written[0].read_text()
    manifest = output.read_manifest(tmp_path)
    assert sorted(manifest) == sorted(p.name for p in written)
    assert all(len(digests) == 1 for digests in manifest.values())


def test_the_circle_figure_is_in_micrometres_about_the_commanded_radius():
    """Koren's sampled loop (K = 18 1/s, τ = 20 ms, T = 1/64 s) on an 8 mm circle at
    40 mm/s: the path is drawn as its deviation in µm, on a ring that shows the commanded
    radius (0 µm), the circularity band and the constraint bound, with a legend naming
    each, the zoomed wedge marked and the zoom in µm."""
    from feedtune.report.figures import circle_figure

    model = ServoModel(18.0, 0.02, 0.015625)
    options = {"radius": 0.008, "feed": 0.04}
    result = {"metrics": {"radial_error": {"metric": "radial_error", "options": options,
                                           "value": 1e-9, "unit": "m"}},
              "constraints": [{"metric": "radial_error", "options": options, "min": None,
                               "max": 5e-6, "value": 1e-9, "satisfied": True}]}
    figure = circle_figure(model, result)
    polar, zoom = figure.axes[0], figure.axes[1]
    deviation = np.asarray(model.circle_test(0.008, 0.04).deviation) * 1e6
    lines = {line.get_label(): line for line in polar.get_lines()}
    assert np.array_equal(lines["path (re-simulated)"].get_ydata(), deviation)
    assert set(lines["commanded radius r = 8 mm (0 µm)"].get_ydata()) == {0.0}
    assert {tuple(set(line.get_ydata())) for line in polar.get_lines()
            if line.get_label().startswith(("constraint", "_"))} >= {(-5.0,), (5.0,)}
    low, high = polar.get_ylim()
    assert low < -5.0 < deviation.min() < deviation.max() < 5.0 < high and low < 0 < high
    assert np.ptp(deviation) > 0.1  # the ripple of the sampled loop, in µm
    legend = [t.get_text() for t in polar.get_legend().get_texts()]
    for label in ("circularity band (max − min)", "constraint |radial error| ≤ 5 µm",
                  "zoomed below", "mean deviation"):
        assert any(text.startswith(label) for text in legend), label
    assert zoom.get_ylabel() == "deviation [µm]" and "zoom" in zoom.get_title()


def test_the_page_states_warnings_a_non_unique_optimum_and_unmet_constraints(tmp_path):
    result = json.loads((DATA / "tian-vf-pulse.result.json").read_text())
    result["warnings"] = ["/objective/0/radius: circle radius 20 m is far outside <practice>"]
    result["optimum"] = {"unique": False, "starts": [1, 2], "spread": {}, "flat": ["position_gain"],
                         "advice": "fix one of them"}
    result["stability"]["stable"] = False
    result["constraints"] = [{"metric": "m_peak", "options": {}, "min": None, "max": 1.3,
                              "value": None, "satisfied": False}]
    page = write_report(result, tmp_path)[0].read_text()
    assert "Implausible: /objective/0/radius: circle radius 20 m is far outside &lt;practice&gt;" in page
    assert "not unique: the objective does not decide position_gain. fix one of them" in page
    assert "not met (loop unstable)" in page and ">OK<" not in page.split("<h2>Constraints</h2>")[1].split("<h2>")[0]


def test_the_pages_plant_parameters_are_those_feedtune_plants_lists():
    """``Result.report`` reads one plant's parameters (``plant_parameters``), not the
    description of every plant: the same list as ``feedtune plants --json`` for every
    registered type, and none for a type no plant has."""
    from feedtune.cli.plants import describe_plants, plant_parameters

    described = describe_plants()
    assert described
    for name, plant in described.items():
        assert plant_parameters(name) == plant["parameters"], name
    assert plant_parameters("no-such-plant") is None
