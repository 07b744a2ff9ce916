"""feedtune.tuner.supremum: peaks over frequency held by the exchange method.

A toy loop with one tunable k and the peak k·ω/(1 + ω²) (largest value k/2 at ω = 1 rad/s):
on a grid that misses ω = 1 the grid alone would allow a larger k than the true bound.
"""

import math
import time

import casadi as ca
import numpy as np
import pytest

from feedtune.expr import Supremum, is_symbolic
from feedtune.expr import Crossing
from feedtune.loops.frequency import peak
from feedtune.tuner.builder import NlpBuilder
from feedtune.tuner.nlp import Problem
from feedtune.tuner.supremum import (EXCHANGE_POINTS, EXCHANGE_TOL, ROW_STRIDE, ExchangeGroup,
                                     FrequencyFunction, add_exchange_points,
                                     make_scan, refined_maximum, supremum_below, tracked,
                                     whole_rows)
from feedtune.tuner.types import Bound, Settings, Term, Variable

GRID = np.array([0.1, 0.5, 2.0, 10.0])  # rad/s; the peak at 1 rad/s falls between points


class ToyLoop:
    """Stable for every k > 0; no horizon, no inner loop."""

    discrete = False
    unrolled_steps = 0

    def __init__(self, k):
        self.k = k

    def stability_conditions(self):
        return [self.k]

    def settling_conditions(self):
        return []

    def embedded_reads(self):
        return frozenset()  # no embedded numbers (Loop protocol)

    def stability_matrices(self):
        return {"closed_loop": ca.reshape(-self.k, 1, 1)}


def toy_peak(loop):
    def fn(omega):
        return loop.k * omega / (1 + omega**2)

    value, where = peak(fn, (0.01, 100.0))
    return Supremum(fn, GRID, value, where)


def test_the_exchange_method_holds_the_true_peak_not_the_grid():
    """max k s.t. peak ≤ 1: on the grid alone k = 1/0.4 = 2.5; the true answer is k = 2."""
    problem = Problem([Variable("k", 0.1, 10.0, initial=1.0)], {},
                      lambda values: ToyLoop(values["k"]),
                      [Term("k", lambda loop: loop.k, -1.0)],
                      [Bound("peak", toy_peak, None, 1.0)], {}, Settings(multistart=1))
    outcome = problem.solve()
    assert outcome.success, outcome.message
    assert outcome.values["k"] == pytest.approx(2.0, rel=1e-6)
    assert outcome.constraints[0][1] == pytest.approx(1.0, rel=1e-6)
    assert outcome.starts[0].exchange_points >= 1


def _on_numbers_only(loop, exact):
    """``locate`` for a Supremum or Crossing of ``loop``: ``exact()`` on a loop of numbers
    (the tuned design's reported value), an error on the NLP's loop of symbols."""
    def locate():
        if is_symbolic(loop.k):
            raise AssertionError("the tuner built the exact value on the loop of symbols")
        return exact()
    return locate


def test_the_tuner_never_builds_the_exact_peak_or_crossing_graph():
    """The exact value of a Supremum or Crossing on the NLP's loop is a large graph; the
    tuner starts its epigraph and crossing variables from the numeric scan instead, so a
    ``locate`` that must not run does not (the answer as with the exact value given)."""
    def lazy_peak(loop):
        given = toy_peak(loop)
        return Supremum(given.fn, GRID,
                        locate=_on_numbers_only(loop, lambda: (given.exact, given.argmax)))

    problem = Problem([Variable("k", 0.1, 10.0, initial=1.0)], {},
                      lambda values: ToyLoop(values["k"]),
                      [Term("k", lambda loop: loop.k, -1.0)],
                      [Bound("peak", lazy_peak, None, 1.0)], {}, Settings(multistart=1))
    outcome = problem.solve()
    assert outcome.success, outcome.message
    assert outcome.values["k"] == pytest.approx(2.0, rel=1e-6)


def test_a_crossing_variable_starts_at_the_scanned_crossing():
    """max over c of the crossing of 1 − ω/c (at ω = c): its variable ln b starts at ln c
    of the start (brentq to 4 eps relative, far inside 1e-12), and the answer is the box's
    top c = 10."""
    def crossing(loop):
        return Crossing(lambda w: 1 - w / loop.k, np.geomspace(1e-3, 1.0, 121)[:-1], None,
                        (0.01, 100.0), locate=_on_numbers_only(loop, lambda: loop.k))

    problem = Problem([Variable("c", 0.1, 10.0, initial=3.0)], {},
                      lambda values: ToyLoop(values["c"]), [Term("b", crossing, -1.0)], [], {},
                      Settings(multistart=1, scalar_search=False))
    assert problem._x0(np.array([math.log(3.0)]))[1] == pytest.approx(math.log(3.0), abs=1e-12)
    outcome = problem.solve()
    assert outcome.success, outcome.message
    assert outcome.values["c"] == pytest.approx(10.0, rel=1e-6)


def test_coarse_grid_rows_then_exchange_rows_switched_off():
    builder = NlpBuilder([Variable("k", 0.1, 10.0)])
    value = toy_peak(ToyLoop(ca.exp(builder.z[0])))
    groups = []
    supremum_below(builder, value, make_scan("peak", value, builder.z, builder.p), 1.0, 1.0,
                   True, groups)
    coarse = len(GRID[::ROW_STRIDE])
    assert builder.g.numel() == coarse + EXCHANGE_POINTS
    assert np.all(builder.ubg[:coarse] == 0) and np.all(builder.ubg[coarse:] == np.inf)
    group = groups[0]
    assert list(group.rows) == list(range(coarse, coarse + EXCHANGE_POINTS))
    (violation, where), *others = group.violations(np.array([math.log(3.0)]), np.zeros(0), 1.0)
    assert violation == pytest.approx(0.5, rel=1e-9)  # peak 1.5 over the bound 1
    assert where == pytest.approx(1.0, rel=1e-6)
    assert all(v < violation for v, _ in others)


def test_rows_are_one_vector_evaluation_and_equal_the_pointwise_values():
    z, p = ca.MX.sym("z", 1), ca.MX.sym("p", 0)
    k = ca.exp(z[0])
    vector = FrequencyFunction("f", lambda w: k * w / (1 + w**2), z, p)
    # w·wᵀ is w² for one ω but 1×1 for a row: not elementwise, so ω is mapped one at a time
    pointwise = FrequencyFunction("g", lambda w: k * ca.sqrt(ca.mtimes(w, w.T))
                                  / (1 + ca.mtimes(w, w.T)), z, p)
    omegas = np.array([0.5, 1.0, 2.0])
    expected = 2.0 * omegas / (1 + omegas**2)
    np.testing.assert_allclose(vector(omegas, np.array([math.log(2.0)]), np.zeros(0)), expected)
    np.testing.assert_allclose(pointwise(omegas, np.array([math.log(2.0)]), np.zeros(0)),
                               expected)
    assert pointwise.function(3).class_name() == "Map"
    rows = ca.Function("rows", [z], [vector.rows(ca.DM(omegas).T)])
    np.testing.assert_allclose(np.asarray(rows(math.log(2.0))).ravel(), expected)


def test_numeric_calls_build_no_row_graph_and_equal_the_rows(monkeypatch):
    """A scan's calls (any number of frequencies) evaluate q(z, p) once and one point(ω, q)
    mapped, not a graph of ``fn`` on a row per row length; the values are the NLP rows'
    values to rounding (relative 1e-14 of a peak of size ≈ 1: the same operations,
    regrouped by the split)."""
    z, p = ca.MX.sym("z", 2), ca.MX.sym("p", 1)
    k, c = ca.exp(z[0]), ca.exp(z[1]) + p[0]
    fn = FrequencyFunction("f", lambda w: k * w / (c + ca.sin(k * c) * w**2), z, p)
    z0, p0 = np.array([math.log(2.0), math.log(0.5)]), np.array([0.25])
    omegas = np.geomspace(0.1, 10.0, 37)
    rows = ca.Function("rows", [z, p], [fn.rows(ca.DM(omegas).T)])
    expected = np.asarray(rows(z0, p0), dtype=float).ravel()

    def no_graph(n):
        raise AssertionError(f"a row graph of {n} frequencies was built")

    monkeypatch.setattr(fn, "function", no_graph)
    for count in (1, 5, 37):
        np.testing.assert_allclose(fn(omegas[:count], z0, p0), expected[:count], rtol=1e-14)
    k1, c1 = math.exp(z0[0] + 0.1), math.exp(z0[1] + 0.1) + 0.25  # a new z: q computed again
    assert fn(np.array([1.0]), z0 + 0.1, p0)[0] == pytest.approx(
        k1 / (c1 + math.sin(k1 * c1)), rel=1e-14)


def test_numeric_calls_read_a_bare_parameter_beside_omega():
    """A plant number standing bare beside ω (a dead time L in sin(ωL), as in
    examples/user-defined-drive.json) is no sub-expression the split can take out: the
    frequency's part reads it as an input (before, its Function failed to build:
    'variables are free'). Values equal the NLP rows to rounding (|f| ≥ 1)."""
    z, p = ca.MX.sym("z", 1), ca.MX.sym("p", 1)
    k = ca.exp(z[0])
    fn = FrequencyFunction("f", lambda w: 2 + k * ca.sin(w * p[0]) / (1 + k), z, p)
    omegas = np.geomspace(0.1, 10.0, 9)
    rows = ca.Function("rows", [z, p], [fn.rows(ca.DM(omegas).T)])
    z0, p0 = np.array([math.log(0.7)]), np.array([0.3])
    np.testing.assert_allclose(fn(omegas, z0, p0), np.asarray(rows(z0, p0)).ravel(),
                               rtol=1e-15)
    np.testing.assert_allclose(fn(omegas, z0, p0), 2 + 0.7 * np.sin(omegas * 0.3) / 1.7,
                               rtol=1e-14)


def test_refined_maximum_finds_a_peak_between_grid_points():
    u = np.log(np.geomspace(0.1, 10.0, 9))  # 1 rad/s is a grid point: shift the peak off it
    top, at = refined_maximum(lambda v: -(v - 0.123) ** 2 + 5.0, u, u[0], u[-1])
    # the value to rounding; its place in ln ω only to √(eps·5) ≈ 3e-8: f is flat there
    assert top == pytest.approx(5.0, abs=1e-15) and at == pytest.approx(0.123, abs=1e-7)


def test_crossing_scan_finds_the_first_crossing():
    """condition 1 − ω/c: crosses 0 at ω = c."""
    z, p = ca.MX.sym("z", 1), ca.MX.sym("p", 0)
    c = ca.exp(z[0])
    crossing = Crossing(lambda w: 1 - w / c, np.geomspace(1e-3, 1.0, 121)[:-1], None,
                        (0.01, 100.0), c)
    scan = make_scan("crossing", crossing, z, p)
    assert scan.exact(np.array([math.log(7.0)]), np.zeros(0)) == pytest.approx(7.0, rel=1e-12)
    dips, where = scan.local_dips(np.array([math.log(7.0)]), np.zeros(0), 5.0, 0.0)
    k = int(np.argmin(dips))  # the condition falls all the way: its lowest value is at b
    assert dips[k] == pytest.approx(1 - 5.0 / 7.0, rel=1e-9) and where[k] == pytest.approx(5.0)


def _group():
    return ExchangeGroup(None, None, (-np.inf, 0.0), slots=[0, 1], rows=range(5, 7))


def test_a_violated_group_switches_on_its_next_row():
    slots, lbg, ubg = np.zeros(2), np.full(7, -np.inf), np.full(7, np.inf)
    used = [0]
    assert add_exchange_points([_group()], [[(0.1, 3.0)]], slots, lbg, ubg, used) is True
    assert used == [1] and slots[0] == 3.0 and ubg[5] == 0.0 and ubg[6] == np.inf


@pytest.mark.parametrize("violation, where", [(EXCHANGE_TOL / 2, 3.0), (1.0, math.nan),
                                              (1.0, 0.0)])
def test_no_point_for_a_tiny_violation_or_no_frequency(violation, where):
    slots, lbg, ubg = np.zeros(2), np.full(7, -np.inf), np.full(7, np.inf)
    assert add_exchange_points([_group()], [[(violation, where)]], slots, lbg, ubg,
                               [0]) is False
    assert np.all(ubg == np.inf)


def test_a_group_out_of_points_says_so():
    slots, lbg, ubg = np.zeros(2), np.full(7, -np.inf), np.full(7, np.inf)
    assert add_exchange_points([_group()], [[(0.1, 3.0)]], slots, lbg, ubg, [2]) is None


def test_every_violated_peak_gets_a_point_in_one_round_while_points_last():
    slots, lbg, ubg = np.zeros(2), np.full(7, -np.inf), np.full(7, np.inf)
    used = [0]
    pairs = [(0.3, 5.0), (0.1, 3.0), (EXCHANGE_TOL / 2, 9.0), (0.05, 7.0)]
    assert add_exchange_points([_group()], [pairs], slots, lbg, ubg, used) is True
    assert used == [2] and list(slots) == [5.0, 3.0]  # the third violated one finds no slot


def _tracked_values(k: float, slots: list[float], step: float, maximum: bool) -> np.ndarray:
    """tracked() on the toy peak ±k·ω/(1 + ω²) (maximum k/2 at ω = 1 rad/s) at ``slots``."""
    z = ca.MX.sym("z")
    sign = 1.0 if maximum else -1.0
    rows = tracked(lambda w: sign * ca.exp(z) * w / (1 + w**2), ca.DM(slots).T, step, maximum)
    return np.asarray(ca.Function("t", [z], [rows])(math.log(k)), dtype=float).ravel()


def test_an_exchange_row_follows_its_peak_when_the_peak_moves():
    """A point added at ω = 1.03 rad/s (say the peak was there, less than a grid step away):
    the row reads the peak k/2 to second order, not the value at 1.03 (4.4e-4 relative
    below it)."""
    step = math.log(10) / 40  # the metrics' grid step in ln ω
    held, at_point = _tracked_values(3.0, [1.03], step, True)[0], 3.0 * 1.03 / (1 + 1.03**2)
    assert abs(held - 1.5) < 1e-2 * abs(at_point - 1.5)  # the fixed point's error, /100
    assert held <= 1.5 + 1e-15  # a value of f: never above its maximum
    # exactly at the peak the point stays put; a dip is followed to its minimum the same way
    assert _tracked_values(3.0, [1.0], step, True)[0] == pytest.approx(1.5, rel=1e-15)
    assert _tracked_values(3.0, [1.03], step, False)[0] == pytest.approx(-held, rel=1e-12)


def test_an_exchange_row_moves_at_most_one_step():
    """Far from the peak (ω = 5, ω = 0.2 rad/s: f convex or steep) the point moves one grid
    step uphill at most."""
    step = math.log(10) / 40
    for omega in (5.0, 0.2):
        held = _tracked_values(1.0, [omega], step, True)[0]
        direction = 1.0 if omega < 1 else -1.0
        reach = omega * math.exp(direction * step)
        assert omega / (1 + omega**2) < held <= reach / (1 + reach**2) + 1e-15



def _resonance_rows(rows_of):
    """(instructions of the rows, of their Jacobian in the tunables) for ``rows_of(row_at,
    slots)`` on a closed loop's |1/D(jω)|², D of degree 10 with coefficients of three
    tunables, at ten slots, expanded to SX as the NLP is."""
    z = ca.MX.sym("z", 3)
    coefficients = [ca.exp(z[k % 3]) * (k + 1) for k in range(11)]

    def row_at(w):
        re, im = 0, 0
        for c in coefficients:  # Horner on jω, as linalg.poly_at_jw
            re, im = -w * im + c, w * re
        return 1 / (re**2 + im**2)

    rows = ca.Function("rows", [z], [rows_of(row_at, ca.DM(np.geomspace(0.5, 2, 10)).T)])
    rows = rows.expand()
    zs = ca.SX.sym("z", 3)
    jacobian = ca.Function("jacobian", [zs], [ca.jacobian(rows(zs), zs)])
    return rows.n_instructions(), jacobian.n_instructions()


def test_a_tracked_row_costs_a_few_evaluations_of_its_row():
    """The slope and curvature in ln ω are central differences, so a tracked row and its
    Jacobian cost four evaluations of the row and theirs (3.4x and 6.7x here), not second
    derivatives differentiated again by IPOPT's Jacobian (10x and 17x before)."""
    step = math.log(10) / 40
    plain = _resonance_rows(lambda row_at, slots: row_at(slots))
    moved = _resonance_rows(lambda row_at, slots: tracked(row_at, slots, step, True))
    assert moved[0] < 5 * plain[0] and moved[1] < 8 * plain[1]


def test_a_row_flat_to_the_last_bit_keeps_a_finite_jacobian():
    """A row whose values at u ± h round to the same number (|T| = 1 at low ω) while its
    derivative in the tunable does not: its differences are 0, and its Newton step must not
    divide their derivatives by 1e-300 (the bundled Ward-Leonard spec's off rows had
    Jacobian entries of 1e256). The row's own derivative is 1e-20·ω (ω ≈ 1 rad/s), so an
    entry of 1e-10 is already ten orders too large."""
    z = ca.MX.sym("z")
    step = math.log(10) / 40
    rows = tracked(lambda w: 1 + ca.exp(z) * 1e-20 * w, ca.DM([[1.0, 2.0]]), step, True)
    jacobian = np.asarray(ca.Function("j", [z], [ca.jacobian(rows, z)])(0.0), dtype=float)
    assert np.all(np.isfinite(jacobian)) and np.max(np.abs(jacobian)) < 1e-10


def test_exchange_rows_compute_what_does_not_depend_on_omega_once():
    """A row whose factor c(k) (2000 operations, no ω) multiplies a peak in ω: 16 tracked
    slots cost c once, not once per slot (a one-slot Function mapped over the slots,
    expanded, repeated it: the NLP's coefficients 16 times per group), and each slot's
    value is the one-slot row's."""
    z = ca.MX.sym("z")
    factor = ca.exp(z)
    for _ in range(1000):
        factor = ca.sin(factor) + factor
    step = math.log(10) / 40

    def expanded(slots):
        rows = tracked(lambda w: factor * w / (1 + w**2), ca.DM(slots).T, step, True)
        return ca.Function("t", [z], [rows]).expand()

    many, one = expanded(list(np.geomspace(0.2, 5.0, 16))), expanded([0.2])
    assert many.n_instructions() - one.n_instructions() < one.n_instructions()  # 15 slots
    values = np.asarray(many(0.3), dtype=float).ravel()
    for omega, value in zip(np.geomspace(0.2, 5.0, 16), values):
        assert value == pytest.approx(float(expanded([omega])(0.3)), rel=1e-14)


def test_a_round_that_goes_on_from_an_optimum_starts_warm():
    """Resumed from where a start ended (its primal and dual point), IPOPT confirms the
    optimum in a couple of iterations; cold (μ = 0.1, pushed off the active bound) it takes
    several and moves away first."""
    problem = Problem([Variable("k", 0.1, 10.0, initial=1.0)], {},
                      lambda values: ToyLoop(values["k"]),
                      [Term("k", lambda loop: loop.k, -1.0)],
                      [Bound("peak", toy_peak, None, 1.0)], {}, Settings(multistart=1))
    assert problem.solve().success
    state = problem._last_state
    z, status, iterations, _, _ = problem._solve_from(None, time.perf_counter(),
                                                      problem.hessians[0], state)
    assert status == "Solve_Succeeded" and math.exp(z[0]) == pytest.approx(2.0, rel=1e-6)
    cold = problem._solver(problem.hessians[0], warm=False)
    p = np.concatenate([[state[1]], state[2], problem.param_values])
    cold(x0=state[0], p=p, lbx=problem.lbw, ubx=problem.ubw, lbg=state[3], ubg=state[4])
    assert iterations <= 2 < cold.stats()["iter_count"]


def test_warm_limited_memory_rounds_put_the_quasi_newton_pairs_into_the_kkt_matrix():
    """A warm-started limited-memory round factorises the KKT matrix with the update's pairs
    as extra rows and columns (one solve a step instead of 2·20 back-solves through
    Sherman-Morrison-Woodbury, benchmarks/README.md); every limited-memory round orders
    MUMPS by approximate minimum fill; the first round keeps IPOPT's update (the extended
    system there sent one order of Bhatia's pole bounds to "infeasible",
    tests/reference/test_new_metrics.py); the exact Hessian keeps IPOPT's defaults. The
    resumed round still confirms the optimum."""
    problem = Problem([Variable("k", 0.1, 10.0, initial=1.0)], {},
                      lambda values: ToyLoop(values["k"]),
                      [Term("k", lambda loop: loop.k, -1.0)],
                      [Bound("peak", toy_peak, None, 1.0)], {}, Settings(multistart=1))
    assert problem.hessians[0] == "limited-memory"
    for warm in (False, True):
        assert problem._options("limited-memory", warm)["ipopt"]["mumps_pivot_order"] == 2
    warm = problem._options("limited-memory", True)["ipopt"]
    assert warm["limited_memory_aug_solver"] == "extended"
    assert "limited_memory_aug_solver" not in problem._options("limited-memory", False)["ipopt"]
    assert "limited_memory_aug_solver" not in problem._options("exact", False)["ipopt"]
    assert problem.solve().success
    z, status, _, _, _ = problem._solve_from(None, time.perf_counter(), "limited-memory",
                                             problem._last_state)
    assert status == "Solve_Succeeded" and math.exp(z[0]) == pytest.approx(2.0, rel=1e-6)


def _resonant_fn(z, p):
    """|T(jω)|² of k/(s² + 2ζω_n s + ω_n²)-like loop numbers of z and p, written as the
    loops write it: Horner on Re and Im of polynomials whose coefficients are expressions of
    the tunables (k = e^z0, ω_n = e^z1, ζ = p0)."""
    k, wn, zeta = ca.exp(z[0]), ca.exp(z[1]), p[0]
    numerator, denominator = [k], [1.0, 2 * zeta * wn, wn**2 + k]

    def at(coefficients, omega):
        re, im = 0, 0
        for c in coefficients:
            re, im = -omega * im + c, omega * re
        return re, im

    def fn(omega):
        n_re, n_im = at(numerator, omega)
        d_re, d_im = at(denominator, omega)
        return (n_re**2 + n_im**2) / (d_re**2 + d_im**2)

    return fn


def test_rows_replay_the_split_point_on_whole_rows():
    """The NLP's rows of a grid are the split's point(ω, q) replayed on the whole row of ω
    (one MX node per point instruction, the graph the same size for 8 or 800 frequencies)
    and the loop's coefficients q one SX Function call: the same operations as ``fn`` on
    the row expanded to SX, so the same values to the bit."""
    z, p = ca.MX.sym("z", 2), ca.MX.sym("p", 1)
    fn = FrequencyFunction("t", _resonant_fn(z, p), z, p)
    z0, p0 = np.array([math.log(4.0), math.log(3.0)]), np.array([0.05])
    sizes = []
    for n in (8, 800):
        omegas = ca.DM(np.geomspace(0.1, 100.0, n)).T
        built = fn.function(n)
        called = {built.instruction_MX(k).which_function().name()
                  for k in range(built.n_instructions()) if built.instruction_id(k) == ca.OP_CALL}
        assert "t_numbers" in called
        sizes.append(built.n_instructions()
                     + sum(built.instruction_MX(k).which_function().n_instructions()
                           for k in range(built.n_instructions())
                           if built.instruction_id(k) == ca.OP_CALL
                           and built.instruction_MX(k).which_function().name() != "t_numbers"))
        rows = ca.Function("rows", [z, p], [fn.rows(omegas)])
        expanded = ca.Function("expanded", [z, p], [fn.fn(omegas)]).expand()
        np.testing.assert_array_equal(np.asarray(rows(z0, p0)), np.asarray(expanded(z0, p0)))
    assert sizes[1] == sizes[0]


def test_frequency_rows_of_whole_vectors_are_solved_unexpanded_to_the_same_optimum():
    """An NLP whose rows are frequency grids (here 200 points, nearly all its rows) is built
    unexpanded (auto): its MX graph is a few vector nodes a grid, and nlpsol skips the SX
    Jacobian of every grid point. Expanded on request, the same optimum (k = 2: the peak
    k/2 at ω = 1 rad/s held at 1), to IPOPT's tolerance on a value of size 2."""
    grid = np.geomspace(0.011, 90.0, 200)

    def bound(loop):
        def fn(omega):
            return loop.k * omega / (1 + omega**2)
        value, where = peak(fn, (0.01, 100.0))
        return Supremum(fn, grid, value, where)

    found = {}
    for expand in (None, True):
        problem = Problem([Variable("k", 0.1, 10.0, initial=1.0)], {},
                          lambda values: ToyLoop(values["k"]),
                          [Term("k", lambda loop: loop.k, -1.0)],
                          [Bound("peak", bound, None, 1.0)], {},
                          Settings(multistart=1, expand=expand, scalar_search=False))
        assert problem._structure.build[2] is (expand is True)
        outcome = problem.solve()
        assert outcome.success, outcome.message
        found[expand] = outcome.values["k"]
    assert found[None] == pytest.approx(2.0, rel=1e-6)
    assert found[None] == pytest.approx(found[True], rel=1e-9)


def test_a_point_with_a_call_is_not_replayed_and_its_rows_are_fn_on_the_row():
    """An instruction that is no unary or binary operation (a call of a Function kept
    through the expansion) is refused by the replay, and the rows come from ``fn`` on the
    row instead: the same values (2·(sin ω + ω²) at k = 2)."""
    x = ca.MX.sym("x")
    g = ca.Function("g", [x], [ca.sin(x) + x**2], {"never_inline": True})
    z, p = ca.MX.sym("z", 1), ca.MX.sym("p", 0)
    k = ca.exp(z[0])
    fn = FrequencyFunction("f", lambda w: k * ca.horzcat(*[g(w[i]) for i in range(w.numel())]),
                           z, p)
    point = fn.split()[0]
    with pytest.raises(ValueError, match="not replayed"):
        whole_rows(point, [ca.MX.sym("w", 1, 3), ca.MX.sym("q", point.sparsity_in(1)), z, p])
    omegas = np.array([0.5, 1.0, 2.0])
    rows = ca.Function("rows", [z], [fn.rows(ca.DM(omegas).T)])
    np.testing.assert_allclose(np.asarray(rows(math.log(2.0))).ravel(),
                               2 * (np.sin(omegas) + omegas**2), rtol=1e-15)
