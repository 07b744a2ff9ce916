"""What a pulse simulation and the search on it keep in memory (issue 15: Tian's tuning
peaked at 1.6 GB): a response holds its own periods, not the horizon's buffers, and the
search keeps numbers per visited point, not loops with their responses."""

from __future__ import annotations

import gc
import tracemalloc
import weakref

from feedtune.objectives import METRICS
from feedtune.plants.pulse_generator import PulseGenerator, PulseGeneratorParams
from feedtune.tuner import Bound, Settings, Term, Variable
from feedtune.tuner.search import SearchProblem

DELTA = 430.0 / 140e3  # rad per pulse (Tian §4)
F = 140e3  # Hz
A_MOTOR = 140e3  # rad/s²


def plant(**overrides):
    params = dict(type="pulse_generator", pulse_equivalent=DELTA, amplitude=10.0,
                  motor_characteristic=[[0, A_MOTOR], [F, A_MOTOR]])
    params.update(overrides)
    return PulseGenerator(PulseGeneratorParams(**params))


def test_a_step_response_holds_only_the_periods_to_rest():
    """Tian's step over a 1 s horizon (140 000 periods) comes to rest after 5 206: what the
    response keeps is its arrays of 5 206 periods (pulse int8, error float64, reference
    int64: 17 B a period, 89 kB), not buffers for the horizon (2.4 MB). Bound: twice the
    arrays' own size, for the dataclass and allocator rounding."""
    loop = plant(duration=1.0).loop({"error_limit": 1.0, "sampling_frequency": F,
                                     "acceleration_ratio": 430.0})
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        response = loop.response
        held = tracemalloc.get_traced_memory()[0] - before
    finally:
        tracemalloc.stop()
    periods = len(response.pulses)
    assert response.at_rest and periods == 5206
    arrays = response.pulses.nbytes + response.error.nbytes + response.reference.nbytes
    assert arrays == 17 * periods
    assert held <= 2 * arrays


def test_the_search_keeps_no_loop_it_visited():
    """Every loop the search simulated is freed once it is scored: only the objective,
    the constraint values and stability of each point are cached."""
    p = plant(amplitude=1.0)
    made = []

    def make_loop(values):
        loop = p.loop(values)
        made.append(weakref.ref(loop))
        return loop

    settling, margin = METRICS["pulse_settling_time"], METRICS["motor_acceleration_margin"]
    problem = SearchProblem(
        [Variable("error_limit", 0.05, 5.0, 1.0), Variable("acceleration_ratio", 100, 5000, 430)],
        {"sampling_frequency": F}, make_loop,
        [Term("pulse_settling_time", lambda loop: settling().evaluate(loop, settling.Options()))],
        [Bound("motor_acceleration_margin", lambda loop: margin().evaluate(loop, None), 0.0, None)],
        {}, Settings(multistart=1, max_iter=3))
    outcome = problem.solve()
    if any(r() is not None for r in made):  # a full collection of the worker's heap
        gc.collect()  # (≈ 1 s in a full run) only where reference counting left a loop
    assert outcome.success and len(made) >= problem.evaluations > 10
    assert [r for r in made if r() is not None] == []
