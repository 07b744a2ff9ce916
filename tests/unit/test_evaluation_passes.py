"""A tuned design's reports computed once where several read the same numbers (issue 15,
branch h-bev5).

Each change must leave every reported number's bits as they were (the batch's 300 result
files are compared field by field in ``benchmarks/batch_throughput.py``); here on Koren's
loops at seeded points of their box, against what the previous code computed.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

import feedtune.loops.frequency as frequency
import feedtune.loops.loop as loop_module
from example_loops import example_loops
from feedtune.loops import linalg
from feedtune.loops.timeresponse import SampledStepError
from feedtune.objectives import METRICS
from feedtune.problem import Reports
from test_design_numbers import _integral_by_dm_calls  # the integral summed alone
from test_report_numbers import _Constant


def _bits(values) -> list[str]:
    """Each number's hex form: equal bits, signed zeros told apart."""
    return [float(v).hex() for v in np.asarray(values, dtype=float).ravel()]


def _stable_sampled_loops(count: int, seed: int) -> list:
    """Sampled Koren loops of numbers at seeded points of the box, the stable ones (an
    unstable loop's integrals are +∞ without a sum)."""
    return [loop for loop in example_loops("sampled", count, seed=seed)
            if loop._numeric_spectral_radius < 1]


def test_a_sampled_loop_of_numbers_sums_its_three_step_integrals_in_one_pass(monkeypatch):
    loops = _stable_sampled_loops(6, seed=41)
    assert len(loops) >= 3
    expected = [[_integral_by_dm_calls(loop, name) for name in ("iae", "ise", "itae")]
                for loop in loops]
    calls = []
    original = frequency.Buffered.__call__

    def spy(self, *args):
        calls.append(self._fn.name())
        return original(self, *args)

    monkeypatch.setattr(frequency.Buffered, "__call__", spy)
    for loop, values in zip(_stable_sampled_loops(6, seed=41), expected):
        calls.clear()
        integrals = loop.step_error_integrals
        got = [integrals.iae, integrals.ise, integrals.itae]
        assert _bits(got) == _bits(values)
        chunks = loop_module._binary_chunks(loop.horizon_samples)
        # main: one fold a chunk and one tail for each integral (3 × (chunks + 1) calls)
        assert len(calls) == len(chunks) + 1, calls


def _dm_recursion(matrix) -> list:
    """Faddeev–LeVerrier on DM operations, as ``linalg.characteristic_polynomial`` ran it
    on a sampled loop's Φ before h-bev5."""
    n = matrix.shape[0]
    coefficients, m_k, c_k = [ca.DM(1.0)], ca.DM.zeros(n, n), ca.DM(1.0)
    for k in range(1, n + 1):
        m_k = ca.mtimes(matrix, m_k) + c_k * ca.DM.eye(n)
        c_k = -ca.trace(ca.mtimes(matrix, m_k)) / k
        coefficients.append(c_k)
    return coefficients


def test_the_characteristic_polynomial_of_a_dense_dm_on_floats_has_the_dm_recursions_bits():
    rng = np.random.default_rng(15)
    for _ in range(400):
        n = int(rng.integers(1, 6))
        a = rng.normal(size=(n, n)) * 10.0 ** float(rng.integers(-6, 6))
        holes = rng.random((n, n)) < 0.3  # exact zeros (signed) and ±1, as a loop's Φ has
        a[holes] = rng.choice([0.0, -0.0, 1.0, -1.0], size=int(holes.sum()))
        matrix = ca.densify(ca.DM(a))
        expected = _dm_recursion(matrix)
        assert _bits(linalg._characteristic_polynomial_of_floats(matrix.full().tolist())) \
            == _bits(expected)  # main: no such function
        got = linalg.characteristic_polynomial(matrix)
        assert all(isinstance(c, ca.DM) for c in got) and _bits(got) == _bits(expected)


def test_a_sampled_loops_stability_conditions_map_floats_to_the_w_plane(monkeypatch):
    loops = example_loops("sampled", 4, seed=43)
    expected = []
    for loop in loops:  # the DM path before h-bev5: the map on DM coefficients
        poly = linalg.bilinear_to_continuous(list(loop.characteristic_polynomial))
        expected.append(linalg.hurwitz_conditions_of_numbers(poly))
    given = []
    bilinear = linalg.bilinear_to_continuous
    monkeypatch.setattr(linalg, "bilinear_to_continuous",
                        lambda poly: given.append(poly) or bilinear(poly))
    for loop, conditions in zip(example_loops("sampled", 4, seed=43), expected):
        assert _bits(loop.stability_conditions()) == _bits(conditions)
    assert given and all(isinstance(c, float) for poly in given for c in poly)  # main: DM


def test_a_sampled_loop_of_numbers_evaluates_its_matrices_once_for_every_report(monkeypatch):
    calls = []
    numbers = loop_module._numbers
    # the graph's path (a structure's later loops read the twin's Function instead, with
    # these bits: tests/unit/test_twin_numbers.py)
    monkeypatch.setattr(loop_module, "replayed_numbers", lambda *args: None)
    monkeypatch.setattr(loop_module, "_numbers",
                        lambda values: calls.append(len(values)) or numbers(values))
    checked = 0
    for loop in example_loops("sampled", 4, seed=47):  # nothing evaluated on them yet
        calls.clear()
        if not loop._numeric_spectral_radius < 1:
            continue
        checked += 1
        for name in ("pole_damping", "decay_rate", "iae", "settling_time", "damping_ratio"):
            metric = METRICS[name]()
            metric.evaluate(loop, metric.Options())
        loop.stability_conditions()
        # Φ, Γ, k_x, k_r, T, τ evaluated together once (main: the polynomial, the held
        # command, the step integrals and each pole metric each evaluated Φ); the
        # conditions' coefficients are numbers already (no Function for them)
        assert calls.count(6) == 1 and len([c for c in calls if c != 3]) == 1, calls
        expected_matrix = np.array(ca.evalf(ca.MX(loop.state_matrix)), dtype=float)
        assert _bits(loop.numeric_state_matrix()) == _bits(expected_matrix)
    assert checked >= 2


def test_the_sampled_step_errors_recurrence_keeps_the_bits_of_phi_at_state_plus_gamma():
    """Not a change of value: the recurrence calls BLAS's product as ``phi @ state`` did
    (the same gemv), so every state has its bits (this passes before h-bev5 too)."""
    for loop in _stable_sampled_loops(4, seed=53):
        phi, gamma, kx, kr, period, tau = loop.numeric_hold()
        samples = loop.horizon_samples + 1
        error = SampledStepError(phi, gamma, kx, kr, period, tau, samples)
        state, states = np.zeros(phi.shape[0]), []
        for _ in range(samples):
            states.append(state)
            state = phi @ state + gamma
        u = np.array(states) @ kx + kr
        x, v = np.array(states)[:, 0], np.array(states)[:, 1]
        assert _bits(error.alpha) == _bits(1 - x - (v - u) * tau)
        assert _bits(error.gamma) == _bits((v - u) * tau)


def test_reports_that_are_dm_numbers_are_kept_as_they_are():
    value = ca.DM(1.25)
    values = Reports({"a": (_Constant(value), None)})._evaluate_all(object())
    assert values["a"] is value  # main: a copy (ca.DM(value), ≈ 23 µs a report)


def test_a_replayed_peaks_last_operations_on_floats_have_the_dm_operations_bits():
    rng = np.random.default_rng(61)
    tops = np.concatenate([rng.uniform(0.5, 3.0, 300), [1.0, 1.0, 2.5]])
    zeros = np.concatenate([rng.uniform(0.5, 3.0, 300), [1.0, 1.0 + 2e-16, 2.5]])
    for top, u, at_zero in zip(tops, rng.uniform(-5.0, 12.0, tops.size), zeros):
        top, u, at_zero = float(top), float(u), float(at_zero)
        expected = (ca.fmax(ca.DM(top), ca.DM(at_zero)),  # peak()'s DM operations before
                    ca.if_else(ca.DM(at_zero) >= ca.DM(top), 0.0, ca.exp(ca.DM(u))))
        got = frequency._peak_numbers(top, u, at_zero)  # main: no such function
        assert all(isinstance(v, ca.DM) for v in got)
        assert _bits(got) == _bits(expected)
