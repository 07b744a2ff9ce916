"""Numbers from what feedtune's loops and metrics return, for the unit tests."""

import casadi as ca
import numpy as np


def as_number(x) -> float:
    """A CasADi scalar expression, a Magnitude's expression or a plain number, as a float."""
    if isinstance(x, (int, float)):
        return float(x)
    return float(np.array(ca.evalf(ca.MX(getattr(x, "expr", x)))).ravel()[0])


def as_numbers(xs) -> np.ndarray:
    """:func:`as_number` of each of ``xs`` (scalars), in one evaluation of their column:
    one CasADi Function for the list instead of one a number (the same operations on each
    entry; the unit tests read hundreds of such lists)."""
    xs = [getattr(x, "expr", x) for x in xs]
    if all(isinstance(x, (int, float)) for x in xs):
        return np.array([float(x) for x in xs])
    column = ca.vertcat(*(ca.MX(x) for x in xs))
    if column.numel() != len(xs):  # an entry that is not a scalar: each as as_number reads it
        return np.array([as_number(x) for x in xs])
    return np.array(ca.evalf(column)).ravel()
