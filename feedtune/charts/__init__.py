"""Koren 1979's design charts (Figs 6, 8, 9), computed by tuning, and technique selection.

:mod:`feedtune.charts.koren` computes the curves of Figs 6 and 8 by tuning specs with
:func:`feedtune.problem.tune` and draws them with matplotlib (Agg, no display);
:mod:`feedtune.charts.selection` holds Koren's summary logic (Fig 9, eqs 1, 2, 23, 26,
27, 11, 40) behind ``feedtune select``.
"""
