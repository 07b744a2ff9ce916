"""The validator's exact time responses (feedtune.validate.continuous, issue 15): the step,
ramp and load responses propagated together (one augmented system, one e^{Mh} per step
size), runs of equal steps in blocks of powers of e^{Mh} (``_propagate``) instead of one
matrix-vector product per step and response. Against the previous code (kept here as the
reference):

* the graded time grid (runs of equal steps now generated at once by np.cumsum, which
  adds in the loop's order) is the previous loop's, to the last bit, on the stored results
  and on perturbed designs (every tuned value ×e^U(−0.4, 0.4), the stable ones of 16);
* a grid without a run of 2·RUN_BLOCK equal steps is the same product, to the last bit;
* on the stored Bhatia and Ward-Leonard results the responses differ from the previous
  per-response, step-by-step ones only by rounding:
  |Δθ| ≤ 1e-12 of the response's own scale (max |θ| in rad, or rad/(N·m) per unit load;
  measured ≤ 4.3e-13 of it), and every validated value by ≤ 1e-3 of the tolerance the
  validator judges it with (the ramp's ITAE weighs the 1e-13 rad noise of t − θ by t:
  measured ≤ 5e-4 of its tolerance), with the same verdicts.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import expm

import feedtune.validate.continuous as continuous
from feedtune.validate import validate_result
from feedtune.validate.models import model_for

DATA = Path(__file__).resolve().parents[1] / "data"
RESULTS = ["bhatia-1971-hydraulic", "ward-leonard-feed-drive"]


def _step_by_step(m, z0, steps):
    """The validator's propagation before issue 15: z ← e^{Mh} z, one step at a time."""
    states = [z0]
    z, cache = z0, {}
    for h in steps:
        step = cache.get(h)
        if step is None:
            step = cache[h] = expm(m * h)
        z = step @ z
        states.append(z)
    return np.array(states)


def _model(name):
    data = json.loads((DATA / f"{name}.result.json").read_text())
    tuned = {key: t["value"] for key, t in data["tuned"].items()}
    return model_for(data["spec"]["plant"], tuned, data.get("stability"))


def test_short_runs_are_the_step_by_step_product_to_the_last_bit():
    rng = np.random.default_rng(15)
    m = rng.normal(size=(5, 5)) - 3 * np.eye(5)
    z0 = rng.normal(size=5)
    steps = np.repeat([1e-3, 2e-3, 1.5e-3, 4e-3], [3, 2 * continuous.RUN_BLOCK - 1, 1, 40])
    assert np.array_equal(continuous._propagate(m, z0, steps), _step_by_step(m, z0, steps))


@pytest.mark.parametrize("length", [2 * continuous.RUN_BLOCK, 5 * continuous.RUN_BLOCK + 7])
def test_a_long_run_is_the_product_up_to_rounding(length):
    """A stable 5-state system over runs of one step: the block powers match step by step
    to 1e-13 of the state's scale."""
    rng = np.random.default_rng(length)
    m = rng.normal(size=(5, 5)) - 4 * np.eye(5)
    z0 = rng.normal(size=5)
    steps = np.concatenate([np.full(3, 1e-3), np.full(length, 2e-3), np.full(5, 3e-3)])
    new, old = continuous._propagate(m, z0, steps), _step_by_step(m, z0, steps)
    assert new.shape == old.shape
    assert np.max(np.abs(new - old)) <= 1e-13 * np.max(np.abs(old))


#: (M, z₀, out, poles as bytes) → (t, θ) of _simulate_before: the responses test and the
#: validated-values test (whose validator builds the same models) read each stored
#: result's responses; computed once per process, as the previous code computed them
_BEFORE: dict = {}


def _simulate_before(model, kind):
    """ContinuousModel._simulate before issue 15: its own grid loop, one augmented system
    per response, e^{Mh} z and θ = out·z one step at a time."""
    m, z0, out = model._augmented(kind)
    key = tuple(np.asarray(a).tobytes() for a in (m, z0, out, model.poles()))
    if key not in _BEFORE:
        steps = _graded_steps_loop(model)
        t = np.concatenate([[0.0], np.cumsum(steps)])
        _BEFORE[key] = t, np.array([out @ z for z in _step_by_step(m, z0, steps)])
    t, theta = _BEFORE[key]
    return t.copy(), theta.copy(), lambda tt: float(out @ expm(m * tt) @ z0)


@pytest.mark.parametrize("name", RESULTS)
@pytest.mark.parametrize("kind", ["step", "ramp", "load"])
def test_responses_of_the_stored_results_differ_by_rounding(name, kind):
    model = _model(name)
    t, theta, exact = model._simulate(kind)
    assert t.size > 10_000  # long runs of equal steps: the block path is taken
    t_old, theta_old, exact_old = _simulate_before(model, kind)
    assert np.array_equal(t, t_old)
    assert np.max(np.abs(theta - theta_old)) <= 1e-12 * np.max(np.abs(theta_old))
    assert exact(t[len(t) // 3]) == exact_old(t[len(t) // 3])


@pytest.mark.parametrize("name", RESULTS)
def test_validated_values_move_by_a_thousandth_of_their_tolerance(name, monkeypatch):
    result = json.loads((DATA / f"{name}.result.json").read_text())
    new = validate_result(result)
    monkeypatch.setattr(continuous.ContinuousModel, "_simulate", _simulate_before)
    old = validate_result(result)
    assert new["ok"] is True and old["ok"] is True
    assert len(new["entries"]) == len(old["entries"]) > 10
    for a, b in zip(new["entries"], old["entries"]):
        assert (a["metric"], a["options"], a["ok"]) == (b["metric"], b["options"], b["ok"])
        if isinstance(b["validated"], float):
            assert abs(a["validated"] - b["validated"]) <= 1e-3 * b["tolerance"], a["metric"]


@pytest.mark.parametrize("name", RESULTS)
def test_the_time_grid_is_computed_once_per_model(name, monkeypatch):
    model = _model(name)
    calls = []
    graded = model._graded_steps
    monkeypatch.setattr(model, "_graded_steps", lambda: calls.append(1) or graded())
    model.responses()
    assert len(calls) == 1


def _graded_steps_loop(model):
    """The validator's time grid before issue 15: one Python iteration per step (each
    mode's fine step FINE/|p| and the times it dies read from lists of floats, not
    recomputed from numpy arrays at every step: the same operations on the same numbers)."""
    p = model.poles()
    speeds, decay = np.abs(p), -p.real
    end = math.log(1 / continuous.SETTLED) / float(np.min(decay))
    order = np.argsort(-speeds)
    dies = (math.log(1 / continuous.ALIVE) / decay[order]).tolist()
    fine = [continuous.FINE / float(speeds[i]) for i in order]
    growth, last = continuous.GROWTH, len(order) - 1
    steps, t, h = [], 0.0, fine[0]
    k = 0
    step, append = fine[0], steps.append  # fine[k], read once per k (the loop is long)
    while t < end:
        while k < last and dies[k] <= t:
            k += 1
            step = fine[k]
        h = h * growth
        if step < h:  # min(h·growth, fine[k]), as min() picks: the same number
            h = step
        append(h)
        t += h
    return np.asarray(steps)


@pytest.mark.parametrize("name", RESULTS)
def test_the_time_grid_is_the_loops_to_the_last_bit(name):
    data = json.loads((DATA / f"{name}.result.json").read_text())
    tuned = {key: t["value"] for key, t in data["tuned"].items()}
    rng = np.random.default_rng(15)
    checked = 0
    for i in range(17):
        values = tuned if i == 0 else {key: v * math.exp(rng.uniform(-0.4, 0.4))
                                       for key, v in tuned.items()}
        model = model_for(data["spec"]["plant"], values, data.get("stability"))
        if not model.stable():
            continue
        new = model._grid_steps()
        assert np.array_equal(new, _graded_steps_loop(model)), values
        checked += 1
    assert checked >= 8


@pytest.mark.parametrize("length", [2 * continuous.RUN_BLOCK - 1, 5 * continuous.RUN_BLOCK + 7])
def test_the_outputs_alone_are_the_states_output_up_to_rounding(length):
    """``output`` c: entry i is c z(t_i), from c P_j in the long runs; against c times the
    kept states, to 1e-13 of the output's scale (rounding of a reordered product)."""
    rng = np.random.default_rng(length)
    m = rng.normal(size=(5, 5)) - 4 * np.eye(5)
    z0, c = rng.normal(size=(5, 2)), rng.normal(size=5)
    steps = np.concatenate([np.full(3, 1e-3), np.full(length, 2e-3), np.full(5, 3e-3)])
    new = continuous._propagate(m, z0, steps, c)
    old = np.einsum("kij,i->kj", continuous._propagate(m, z0, steps), c)
    assert new.shape == old.shape == (steps.size + 1, 2)
    assert np.max(np.abs(new - old)) <= 1e-13 * np.max(np.abs(old))


def _outputs_block_by_block(m, z0, steps, c):
    """``_propagate``'s output rows before the stacked product: each block of a long run
    (c P_j) z by its own matrix product, z advanced by P_RUN_BLOCK after it."""
    states = np.empty((steps.size + 1,) + z0.shape[1:])
    states[0] = c @ z0
    z, i, block = z0, 0, continuous.RUN_BLOCK
    while i < steps.size:
        h = steps[i]
        end = i + int(np.argmax(steps[i:] != h)) if np.any(steps[i:] != h) else steps.size
        step = expm(m * h)
        if end - i < 2 * block:
            for k in range(i, end):
                z = step @ z
                states[k + 1] = c @ z
        else:
            powers = [step]
            for _ in range(block - 1):
                powers.append(step @ powers[-1])
            powers = np.array(powers)
            seen = c @ powers
            while i < end:
                k = min(block, end - i)
                states[i + 1:i + 1 + k] = seen[:k] @ z
                z = powers[k - 1] @ z
                i += k
        i = end
    return states


@pytest.mark.parametrize("columns", [None, 2])
def test_a_long_runs_outputs_in_one_stacked_product_are_each_blocks_to_the_bit(columns):
    """The output rows of whole blocks computed as one stacked product are the rows each
    block's own product gave, bit for bit (a vector state and a matrix of states)."""
    rng = np.random.default_rng(16)
    m = rng.normal(size=(6, 6)) - 3 * np.eye(6)
    z0 = rng.normal(size=(6,) if columns is None else (6, columns))
    c = rng.normal(size=6)
    block = continuous.RUN_BLOCK
    steps = np.concatenate([np.full(5, 1e-3), np.full(7 * block + 11, 2e-3),
                            np.full(2 * block, 3e-3)])
    new = continuous._propagate(m, z0, steps, c)
    assert new.tobytes() == _outputs_block_by_block(m, z0, steps, c).tobytes()
