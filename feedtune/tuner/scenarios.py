"""An objective that is the worst of several: the largest of groups of weighted terms.

Robust tuning (feedtune.robust) puts the same objective terms on several loops (one per
scenario of the plant's uncertain numbers) and asks for the design whose worst scenario
is best: minimise max_g F_g, F_g = Σ_{terms i of group g} w_i·v_i. The tuner sees only
:attr:`~feedtune.tuner.types.Term.group`; one group is the plain sum, as before. The max is
made smooth by an epigraph: a variable t with t ≥ F_g for every group, minimise t.
"""

from __future__ import annotations

import functools

import casadi as ca

from feedtune.tuner.builder import Lazy, NlpBuilder


def objective_value(weights, values, groups) -> float | None:
    """max over groups of Σ weight·value (None when a value is None): the objective the
    NLP minimises, of numbers."""
    if any(v is None for v in values):
        return None
    sums: dict[int, float] = {}
    for weight, value, group in zip(weights, values, groups):
        sums[group] = sums.get(group, 0.0) + weight * value
    return max(sums.values()) if sums else 0.0


def worst_group(builder: NlpBuilder, shares: list, groups: list[int], scale: float):
    """The NLP's objective from each term's share (its :func:`~feedtune.tuner.terms.add_term`
    expression) and group: their sum for one group; else an epigraph variable t with
    rows (t − F_g)/s ≥ 0, s a parameter (``scale``, the objective's size at the starts),
    started at the largest F_g where each auxiliary variable starts. The shares, rows and
    start are built by a symbolic builder only (None from another: see
    feedtune.tuner.builder.Lazy)."""
    order = list(dict.fromkeys(groups))

    @functools.cache
    def group_sums() -> dict:  # built once, by a symbolic builder only
        sums = {g: ca.MX(0) for g in order}
        for share, group in zip(shares, groups):
            sums[group] += share
        return sums

    if len(order) <= 1:
        return builder.expression(Lazy(lambda: group_sums()[order[0]] if order else ca.MX(0)))
    s = builder.parameter("objective_group_scale", scale)
    extra, extra_start = builder.extra, list(builder.extra_start)

    def start():
        sums = group_sums()
        starts = [ca.substitute(sums[g], ca.vertcat(*extra), ca.vertcat(*extra_start))
                  if extra else sums[g] for g in order]
        return ca.mmax(ca.vertcat(*starts)) / s

    t = builder.variable("worst_group", -ca.inf, ca.inf, Lazy(start))
    for g in order:
        builder.constrain(Lazy(lambda g=g: (s * t - group_sums()[g]) / s), 0, ca.inf)
    return builder.expression(Lazy(lambda: s * t))
