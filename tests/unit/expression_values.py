"""Numbers from what feedtune's loops and metrics return, for the unit tests."""

import casadi as ca
import numpy as np


def as_number(x) -> float:
    """A CasADi scalar expression, a Magnitude's expression or a plain number, as a float."""
    if isinstance(x, (int, float)):
        return float(x)
    return float(np.array(ca.evalf(ca.MX(getattr(x, "expr", x)))).ravel()[0])


def as_numbers(xs) -> np.ndarray:
    return np.array([as_number(x) for x in xs])
