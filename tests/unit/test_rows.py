"""An SX Function over a long row by numpy (feedtune.loops.rows): CasADi's bits, and the
min_radius scan that reads it (issue 15)."""

import math

import casadi as ca
import numpy as np
import pytest
from example_loops import example_loops

import feedtune.loops.rows as rows
import feedtune.objectives.contour.min_radius as min_radius
from feedtune.loops.frequency import replayed
from feedtune.loops.twin import OfLoop
from feedtune.objectives import METRICS


def _bits(values) -> np.ndarray:
    return np.asarray(values, dtype=float).view(np.int64)


def _casadi_row(fn, x, *fixed) -> np.ndarray:
    """``fn`` at each element of ``x`` by CasADi's own map (the reference)."""
    shared = [False] + [True] * (fn.n_in() - 1)
    mapped = fn.map(x.size, shared, [False] * fn.n_out())
    return np.array(mapped(x.reshape(1, -1), *fixed), dtype=float).ravel()


@pytest.mark.parametrize("kind", ["pulse", "sampled"])
def test_row_gives_the_bits_of_casadis_map_on_the_min_radius_excess(kind):
    rng = np.random.default_rng(7)
    for loop in example_loops(kind, 4, seed=3):
        excess = replayed("min_radius_excess", OfLoop(min_radius._excess, loop), 0,
                          log_omega=False)[0][0]
        row = rows.Row(excess.fn)
        low = math.log(loop.drive.max_velocity / float(loop.velocity_constant))
        scan = low + np.arange(1601) * math.log(10) / 400
        far = low + rng.uniform(-5.0, 40.0, 2000)  # beyond the scan, down to ω → 0
        for u in (scan, far, scan[:1]):
            assert np.array_equal(_bits(row(u, *excess.fixed)), _bits(excess(u)))


def test_row_takes_every_operation_with_casadis_bits():
    x, p = ca.SX.sym("x"), ca.SX.sym("p", 3)
    numbers = ca.exp(p[0]) * ca.sin(p[1]) + 1 / p[2]  # the fixed inputs alone: scalars
    y = (x ** 2 - 2 * x + ca.sqrt(ca.fabs(x)) / (1 + x ** 2) - x / numbers
         + ca.exp(-x) * ca.cos(3 * x) + ca.log(ca.fabs(x) + p[1]) + ca.atan2(x, p[0])
         + ca.fmax(x, p[2]) + ca.if_else(x < p[1], -x, 1 / x) + 0.1)
    fn = ca.Function("every", [x, p], [y])
    kinds = {fn.instruction_id(k) for k in range(fn.n_instructions())}
    assert {ca.OP_SQ, ca.OP_TWICE, ca.OP_INV, ca.OP_NEG, ca.OP_SQRT, ca.OP_FABS, ca.OP_DIV,
            ca.OP_EXP, ca.OP_SIN, ca.OP_COS, ca.OP_LOG, ca.OP_ATAN2, ca.OP_FMAX,
            ca.OP_LT} <= kinds
    fixed = np.array([0.3, -1.7, 2.5])
    u = np.concatenate([np.random.default_rng(1).normal(0, 10, 3000),
                        [0.0, -0.0, 1e-310, -1e300, np.inf, -np.inf, np.nan, 1.7, -1.7]])
    assert np.array_equal(_bits(rows.Row(fn)(u, fixed)), _bits(_casadi_row(fn, u, fixed)))
    constant = ca.Function("constant", [x, p], [ca.exp(p[0]) + 0 * x])  # x folded away
    assert np.array_equal(_bits(rows.Row(constant)(u[:5], fixed)),
                          _bits(_casadi_row(constant, u[:5], fixed)))


def test_row_of_is_none_for_a_function_it_cannot_take():
    x = ca.MX.sym("x")
    assert rows.row_of(("test", "mx"), ca.Function("mx", [x], [ca.sin(x)])) is None
    v = ca.SX.sym("v", 2)
    assert rows.row_of(("test", "vector"), ca.Function("vector", [v], [v[0] * v[1]])) is None
    s = ca.SX.sym("s")
    kept = rows.row_of(("test", "scalar"), ca.Function("scalar", [s], [ca.sin(s)]))
    assert kept is not None
    assert rows.row_of(("test", "scalar"), None) is kept  # built once per key


@pytest.mark.parametrize("kind", ["pulse", "sampled"])
def test_min_radius_scans_by_rows_with_the_bits_of_the_map(kind, monkeypatch):
    metric = METRICS["min_radius"]()
    scanned = []
    original = rows.Row.__call__
    monkeypatch.setattr(rows.Row, "__call__",
                        lambda self, x, *fixed: scanned.append(np.size(x)) or original(
                            self, x, *fixed))
    loops = example_loops(kind, 4, seed=11)
    by_rows = [float(ca.evalf(metric.evaluate(loop, None))) for loop in loops]
    assert scanned and all(size >= 1600 for size in scanned)  # the scan's rows, nothing else
    monkeypatch.setattr(min_radius, "_scan", lambda loop, excess: None)
    by_map = [float(ca.evalf(metric.evaluate(loop, None))) for loop in loops]
    assert _bits(by_rows).tolist() == _bits(by_map).tolist()
