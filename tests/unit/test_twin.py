"""A loop of numbers' parametric twin (feedtune.loops.twin) and the Functions replayed on
it (feedtune.loops.frequency.replayed): issue 15, the exact evaluation of a batch spec.

The twin's Functions must give what the Functions built on the loop of numbers give, and a
second loop of the same structure must build none. Bits: on Koren's reference-pulse loop
the values are equal to the last bit; on the sampled loop |T/T(1)|² differs by the
rounding of the DC gain the loop of numbers computes, N(1)/(D(1) + N(1)) with D(1) =
1 − (1 + x) + x summed in floats (≈ 1e-16 where it is 0), divided by N(1) ≈ 1e-3 …
1e-2: ≤ 1e-12 relative (the twin's graph simplifies D(1) to 0, as the NLP's does).
"""

from __future__ import annotations

import math
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

import feedtune.loops.frequency as frequency
from feedtune.expr import to_float
from feedtune.loops.twin import OfLoop, parametric_twin
from feedtune.objectives.contour.min_radius import MinRadius
from feedtune.objectives.frequency import frequency_domain
from feedtune.objectives.frequency.gain_margin import GainMargin
from feedtune.objectives.frequency.m_peak import MPeak
from feedtune.objectives.frequency.phase_margin import PhaseMargin
from feedtune.objectives.frequency.sensitivity_peak import SensitivityPeak, sensitivity_squared
from feedtune.problem import build_plant, resolve_tunables
from feedtune.schema.spec import parse_spec
from feedtune.tuner.terms import exact_value

REPO = Path(__file__).resolve().parents[2]
KINDS = {"pulse": "koren-1979-reference-pulse", "sampled": "koren-1979-sampled-data"}
#: the sampled |T/T(1)|²'s DC gain rounding (module docstring) bounds the relative change
SAMPLED_REL = 1e-12


def _plant_box(kind):
    spec = parse_spec((REPO / "examples" / f"{KINDS[kind]}.json").read_text())
    plant = build_plant(spec)
    _, _, box = resolve_tunables(spec, plant)
    return plant, box


def _loops(kind, count=3):
    """``count`` loops of numbers at seeded log-uniform points of the example's box."""
    plant, box = _plant_box(kind)
    rng = np.random.default_rng(15)
    return [plant.loop({name: math.exp(rng.uniform(math.log(lo), math.log(hi)))
                        for name, (lo, hi) in box.items()}, box) for _ in range(count)]


@pytest.mark.parametrize("kind", KINDS)
def test_loops_of_one_structure_share_one_twin(kind):
    first, second = _loops(kind, 2)
    a, b = parametric_twin(first), parametric_twin(second)
    assert a.structure == b.structure and a.loop is b.loop and a.numbers is b.numbers
    assert a.values.shape == b.values.shape and not np.array_equal(a.values, b.values)
    assert parametric_twin(first) is a  # kept on the loop


def test_a_loop_of_symbols_has_no_twin():
    plant, box = _plant_box("sampled")
    symbols = {name: ca.MX.sym(name) for name in box}
    assert parametric_twin(plant.loop(symbols, box)) is None



def test_a_loop_of_numbers_is_described_without_walking_its_graphs_for_symbols(monkeypatch):
    """A loop of numbers' twin needs no ``ca.symvar`` on its leaves (the reference-pulse
    loop's two MX leaves: ≈ 0.09 ms a batch spec, benchmarks/README.md h-bx2): a loop of
    symbols is found where the twin's numbers are evaluated (above); the same twin."""
    import feedtune.loops.twin as twin_module

    expected = parametric_twin(_loops("pulse", 1)[0])  # the pulse loop has MX leaves
    loop, = _loops("pulse", 1)

    def refused(*args):
        raise AssertionError("ca.symvar called")

    monkeypatch.setattr(twin_module.ca, "symvar", refused)
    twin = parametric_twin(loop)
    monkeypatch.undo()
    assert twin is not None and twin.structure is expected.structure
    assert twin.values.tobytes() == expected.values.tobytes()

def test_other_choices_are_another_structure():
    plant, box = _plant_box("sampled")
    values = {name: math.sqrt(lo * hi) for name, (lo, hi) in box.items()}
    other = type(plant)(plant.params.model_copy(update={"computation_delay": 1}))
    assert (parametric_twin(plant.loop(values, box)).structure
            != parametric_twin(other.loop(values, box)).structure)


def _built(fn, derivatives):
    """The row evaluators of ``fn`` and its u-derivatives built on the loop of numbers
    itself (the path before the twin: SX directly, else the expanded MX Functions)."""
    numbers = frequency._number_functions("f", fn, derivatives)
    if numbers is None:
        numbers, free = frequency._functions("f", fn, derivatives)
        assert not free
    return [frequency.Mapped(g) for g in numbers]


#: (CasADi Function names are identifiers) |T/T(0)|², |S|², ln|L|², −Im L/|L|
RESPONSES = {"gain_squared": frequency_domain.normalised_gain_squared,
             "sensitivity_squared": lambda loop: OfLoop(sensitivity_squared, loop),
             "log_open_loop_gain": frequency_domain.log_open_loop_gain_squared,
             "phase_indicator": frequency_domain.phase_crossover_indicator}


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("response", RESPONSES)
def test_replayed_functions_give_the_loops_values(kind, response):
    for loop in _loops(kind):
        fn = RESPONSES[response](loop)
        grid = np.log(frequency.log_grid(loop.frequency_band))
        rows, _ = frequency.replayed(f"test_{response}", fn, 2)
        for new, old in zip(rows, _built(fn, 2)):
            a, b = new(grid), old(grid)
            if kind == "pulse" or response != "gain_squared":
                assert np.array_equal(a, b, equal_nan=True), response
            else:
                assert np.allclose(a, b, rtol=SAMPLED_REL, atol=0, equal_nan=True)


@pytest.mark.parametrize("kind", KINDS)
def test_a_second_loop_builds_nothing(kind, monkeypatch):
    calls = []
    build = frequency._replay_functions
    monkeypatch.setattr(frequency, "_replay_functions",
                        lambda *args: calls.append(args[0]) or build(*args))
    for loop in _loops(kind):
        frequency.replayed("test_second", frequency_domain.normalised_gain_squared(loop), 2)
    assert calls == ["test_second"]


def _shaping(loop):
    """A function whose graph a number of the loop shapes (a count of terms, a branch):
    not replayable."""
    terms = range(math.ceil(loop.gain))
    branch = 1.0 if loop.period < 0.01 else 2.0

    return lambda omega: sum(omega**k for k in terms) * branch


def test_a_number_that_shapes_the_graph_is_not_replayed():
    loop = _loops("sampled", 1)[0]
    assert frequency.replayed("test_shaping", OfLoop(_shaping, loop), 1) is None


METRICS = [MPeak, SensitivityPeak, GainMargin, PhaseMargin, MinRadius]


def _reported(metric, loop) -> float:
    expr, magnitude = exact_value(metric.evaluate(loop, metric.Options()))
    value = to_float(ca.evalf(ca.MX(expr)))
    return abs(value) if magnitude else value


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("metric", METRICS, ids=lambda m: m.name)
def test_metrics_as_reported(kind, metric, monkeypatch):
    """The values a result reports, replayed and built on each loop (replay off)."""
    m = metric()
    plant, box = _plant_box(kind)
    rng = np.random.default_rng(16)
    points = [{name: math.exp(rng.uniform(math.log(lo), math.log(hi)))
               for name, (lo, hi) in box.items()} for _ in range(3)]
    new = [_reported(m, plant.loop(p, box)) for p in points]
    monkeypatch.setattr(frequency, "replayed", lambda *args, **kwargs: None)
    import feedtune.objectives.contour.min_radius as min_radius

    monkeypatch.setattr(min_radius, "replayed", lambda *args, **kwargs: None)
    old = [_reported(m, plant.loop(p, box)) for p in points]
    if kind == "sampled" and m.name == "m_peak":
        assert np.allclose(new, old, rtol=SAMPLED_REL, atol=0, equal_nan=True)
    else:
        assert np.array_equal(new, old, equal_nan=True), (new, old)


def test_threads_evaluate_their_own_numbers():
    """Loops of one structure in two threads (a Dask worker runs specs in threads) share
    the replayed Functions but not their buffers: each thread reads its own loop's values.
    A short switch interval makes the threads interleave between filling a buffer and
    reading it."""
    import sys
    import threading

    loops = _loops("sampled", 2)
    grid = np.log(frequency.log_grid(loops[0].frequency_band))
    rows = [frequency.replayed("test_threads", frequency_domain.normalised_gain_squared(loop),
                               0)[0][0] for loop in loops]
    expected = [row(grid) for row in rows]
    wrong = []

    def run(i):
        for _ in range(300):
            if not np.array_equal(rows[i](grid), expected[i], equal_nan=True):
                wrong.append(i)

    interval = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    try:
        threads = [threading.Thread(target=run, args=(i,)) for i in (0, 1)]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
    finally:
        sys.setswitchinterval(interval)
    assert not wrong
