"""Pole regions in the NLP: a decay rate or damping ratio of every closed-loop pole.

A :class:`~feedtune.expr.PoleRegion`'s value, a minimum over the poles, is not smooth;
the NLP holds "every pole's measure > level" instead by the region's factor form where
it has one (auxiliary variables: the coefficients of the real factors of the
characteristic polynomial, equality rows matching their product to it, a few rows per
factor; :func:`factor_rows`), else by its polynomial conditions (Hurwitz conditions of a
shifted characteristic polynomial), written as the stability rows are
(:func:`feedtune.tuner.stability.add_stability_rows`): each
condition divided by its magnitude at the first start (an NLP parameter) inside asinh,
≥ STABILITY_MARGIN for a bound, ≥ TERM_MARGIN when maximised. The value itself is
computed numerically from the poles (:class:`PoleScan`), as a peak's is by its scan.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from feedtune.expr import Factors, PoleRegion
from feedtune.tuner.builder import NlpBuilder, scale
from feedtune.tuner.stability import STABILITY_MARGIN
from feedtune.tuner.starts import starting_points

#: scaled conditions of a maximised region must exceed this [1] (a bound's, like the
#: stability rows, STABILITY_MARGIN): 100 times IPOPT's tol (1e-9), so the tuned design
#: lies strictly inside. Where the optimum has two poles meeting (a double root), a
#: violation ε moves them by √ε, while a margin m keeps them a complex pair inside and the
#: value O(m) below the optimum: measured on Koren's sampled loop, 1e-9 left it 6e-5
#: relative short, 1e-7 1.4e-9. Not for bounds: there the margin moves the bound by m
#: times (row scale)/(slope in the level), and with 1e-7 σ_min ≥ 12 1/s on Bhatia's drive
#: tuned to 12.000009; with 3e-8 or 1e-8 on bounds his two-gain case with ζ_min ≥ 0.3,
#: σ_min ≥ 8 1/s and M_s ≤ 2 ended "infeasible" (see docs/design.md, pole regions).
TERM_MARGIN = 1e-7


class PoleScan:
    """A PoleRegion's value at numbers: its ``measure`` of the inputs (the state matrix and
    period) evaluated at log tunables ``z`` and parameters ``p``."""

    def __init__(self, name: str, value: PoleRegion, z, p):
        self.measure = value.measure
        self.n_params = p.numel()
        self.inputs = ca.Function(name, [z, p], [value.inputs])

    def exact(self, z, p) -> float:
        """The region's value [its unit] from the numeric poles."""
        return self.measure(np.asarray(self.inputs(z, p[:self.n_params]), dtype=float))


def region_above(builder: NlpBuilder, value: PoleRegion, level, probe_level, name: str,
                 margin: float) -> None:
    """Rows asinh(c/s_c) ≥ ``margin`` for every condition c of ``value.conditions(level)``
    (or of its factor form, :func:`factor_rows`):
    every pole's measure above ``level`` (an expression of the NLP's variables and
    parameters). Each scale s_c is an NLP parameter, |c| at the first start with the
    level ``probe_level`` (an expression of the parameters alone)."""
    if value.conditions is None:
        raise ValueError(f"{name}: no polynomial test for this pole region on this loop")
    start = starting_points(builder.variables, 1)[0]
    if value.factors is not None:
        conditions, sizes = factor_rows(builder, value, level, probe_level, start, name)
    else:
        conditions = value.conditions(level)
        probe = ca.Function("probe", [builder.z, builder.p],
                            [ca.vertcat(ca.MX(0, 1), *value.conditions(probe_level))])
        sizes = np.abs(np.asarray(probe(start, builder.param_values), dtype=float)).ravel()
    for i, (condition, size) in enumerate(zip(conditions, sizes)):
        s = builder.parameter(f"{name}_scale{i}", scale(size))
        builder.constrain(ca.asinh(condition / s), margin, ca.inf)


class FactorScan:
    """Start of factor variable ``index`` of a region's :class:`~feedtune.expr.Factors`:
    the factors of the numeric poles at log tunables ``z`` and parameters ``p``."""

    def __init__(self, factors: Factors, inputs: ca.Function, index: int):
        self.factors, self.inputs, self.index = factors, inputs, index
        self.n_params = inputs.size1_in(1)

    def exact(self, z, p) -> float:
        numbers = np.asarray(self.inputs(z, p[:self.n_params]), dtype=float)
        return float(self.factors.start(numbers)[0][self.index])


def factor_rows(builder: NlpBuilder, value: PoleRegion, level, probe_level, start,
                name: str) -> tuple[list, np.ndarray]:
    """The region's factor form: auxiliary variables x (each divided by its magnitude at
    ``start``, a parameter, and started at the factors of the numeric poles of each start)
    and the equality rows residual/magnitude = 0 that tie them to the loop; returns the
    conditions on x at ``level`` and their sizes at ``start`` with ``probe_level``."""
    factors = value.factors
    inputs = ca.Function(f"{name}_inputs", [builder.z, builder.p], [value.inputs])
    x0, magnitudes = factors.start(np.asarray(inputs(start, builder.param_values), dtype=float))
    x = []
    for i in range(factors.size):
        s = builder.parameter(f"{name}_factor_scale{i}", scale(magnitudes[i]))
        x.append(s * builder.variable(f"{name}_factor{i}", -ca.inf, ca.inf,
                                      lambda v, s=s: v / s, FactorScan(factors, inputs, i)))
        builder.restarted.append(len(builder.extra) - 1)
    symbol = ca.MX.sym(f"{name}_factors", factors.size)
    residuals, sizes = zip(*factors.matching(symbol))
    probe = ca.Function("probe", [symbol, builder.z, builder.p],
                        [ca.vertcat(*sizes), ca.vertcat(ca.MX(0, 1),
                                                        *factors.conditions(probe_level, symbol))])
    row_sizes, condition_sizes = (np.abs(np.asarray(v, dtype=float)).ravel() for v in
                                  probe(np.nan_to_num(x0), start, builder.param_values))
    matched = ca.Function("matched", [symbol, builder.z, builder.p], [ca.vertcat(*residuals)])
    residual = matched(ca.vertcat(*x), builder.z, builder.p)
    for i, size in enumerate(row_sizes):
        r = builder.parameter(f"{name}_match_scale{i}", scale(size))
        builder.constrain(residual[i] / r, 0, 0)
    return factors.conditions(level, ca.vertcat(*x)), condition_sizes


def region_bound(builder: NlpBuilder, value: PoleRegion, index: int, lower: float) -> None:
    """Constraint ``lower`` ≤ the region's value (a parameter holds ``lower``)."""
    level = builder.parameter(f"bound_lower{index}", lower)
    region_above(builder, value, level, level, f"region_bound{index}", STABILITY_MARGIN)


def region_term(builder: NlpBuilder, value: PoleRegion, index: int, reference: float | None):
    """The region's value as an epigraph variable s·t, held below the value by
    ``conditions(s·t)``, s the term's scale (a parameter); for maximisation only. Starts
    at t = 0, where the conditions are the loop's stability (a stable start meets them)."""
    s_value = scale(reference)
    s = builder.parameter(f"term_scale{index}", s_value)
    t = builder.variable(f"region{index}", value.lower / s_value, value.upper / s_value,
                         ca.MX(0))
    region_above(builder, value, s * t, ca.MX(0), f"region_term{index}", TERM_MARGIN)
    return s * t
