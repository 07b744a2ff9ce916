"""Is the optimum unique? Second-order conditions at the solution, and starts that tie."""

from __future__ import annotations

import math
import threading
import weakref
from dataclasses import dataclass

import numpy as np

from feedtune.tuner.calls import numeric
from feedtune.tuner.types import Variable

#: the objective (divided by its value at the start) curves less than this along a direction
#: of ln(tunables) allowed by the active constraints: a flat direction, the optimum not unique
FLAT_CURVATURE = 1e-6
#: a multiplier larger than this (relative to 1 and the largest) makes its constraint active
ACTIVE_MULTIPLIER = 1e-6
#: a tunable moves along a flat direction when its share of the direction exceeds this
FLAT_SHARE = 0.1
#: two starts reach the same optimum when their objectives differ by less than this,
#: relative to the larger of the best objective and the objective's scale at the starts
SAME_OPTIMUM_TOL = 1e-6


@dataclass(frozen=True)
class Solution:
    """The last NLP round of a start: variables ``x``, parameters ``p``, multipliers of the
    rows and of the variable bounds, and the row bounds it was solved with."""

    x: np.ndarray
    p: np.ndarray
    lam_g: np.ndarray
    lam_x: np.ndarray
    lbg: np.ndarray
    ubg: np.ndarray


#: step [1] along a unit direction of the NLP's variables (log tunables) for the curvature
#: by central differences of the exact gradient, where IPOPT has no Hessian (limited
#: memory): truncation ~ step² · third derivative, rounding ~ 1e-16/step, both ≪ FLAT_CURVATURE
CURVATURE_STEP = 1e-5


#: each solver's derivative Functions by name, taken from it once (``get_function`` returns a
#: new proxy at every call, and :func:`~feedtune.tuner.calls.numeric` keys on the proxy):
#: kept while the solver is (a cached solver serves every problem of its structure)
_derivatives: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_derivatives_lock = threading.Lock()


def _derivative(solver, name: str):
    """The :func:`~feedtune.tuner.calls.numeric` call of the solver's Function ``name``
    (``nlp_jac_g``, ``nlp_hess_l``): the same evaluation as a call with DMs, so the same
    bits, without the DM conversions (≈ 50 µs a call of the batch's 2-variable NLPs
    against ≈ 12 µs, benchmarks/README.md, branch h-bst5)."""
    with _derivatives_lock:
        functions = _derivatives.setdefault(solver, {})
        if name not in functions:
            functions[name] = solver.get_function(name)
        function = functions[name]
    return numeric(function)


def _curvature(solver, solution: "Solution", directions: np.ndarray) -> np.ndarray:
    """directionsᵀ H directions, H the Hessian of f + λᵀg at ``solution``: IPOPT's own
    (``nlp_hess_l``), or central differences of the exact gradient f′ + g′ᵀλ along each
    direction when IPOPT approximates it (limited memory) and has built none."""
    x, p, lam_g = solution.x, solution.p, solution.lam_g
    if solver.has_function("nlp_hess_l"):
        triu = _derivative(solver, "nlp_hess_l")(x, p, 1.0, lam_g)
        return directions.T @ (triu + np.triu(triu, 1).T) @ directions
    grad_f, jac_g = solver.get_function("nlp_grad_f"), solver.get_function("nlp_jac_g")

    def gradient(point):
        return (np.asarray(grad_f(point, p)[1], dtype=float).ravel()
                + np.asarray(jac_g(point, p)[1].full()).T @ lam_g)

    columns = [(gradient(x + CURVATURE_STEP * d) - gradient(x - CURVATURE_STEP * d))
               / (2 * CURVATURE_STEP) for d in directions.T]
    reduced = directions.T @ np.column_stack(columns)
    return (reduced + reduced.T) / 2


def flat_tunables(solver, solution: Solution, variables: list[Variable]) -> list[str]:
    """Tunables that move along a flat direction of the NLP at ``solution``.

    The Hessian of the Lagrangian (with IPOPT's multipliers, see :func:`_curvature`)
    reduced to the directions that keep every active constraint and bound (a multiplier
    above ACTIVE_MULTIPLIER, or an equality) unchanged to first order. A
    reduced curvature below FLAT_CURVATURE (the objective is divided by its value at the
    start, the tunables are logarithms) is a direction in which the optimum is not unique,
    e.g. zero radial error along a curve K(T).
    """
    from scipy import linalg

    x, p, lam_g, lam_x, lbg, ubg = (solution.x, solution.p, solution.lam_g, solution.lam_x,
                                    solution.lbg, solution.ubg)
    threshold = ACTIVE_MULTIPLIER * max(1.0, float(np.max(np.abs(lam_g), initial=0.0)),
                                        float(np.max(np.abs(lam_x), initial=0.0)))
    _, jacobian = _derivative(solver, "nlp_jac_g")(x, p)
    rows = [i for i in range(len(lbg)) if (lbg[i] == ubg[i] and math.isfinite(lbg[i]))
            or (abs(lam_g[i]) > threshold and (math.isfinite(lbg[i]) or math.isfinite(ubg[i])))]
    active = np.vstack([jacobian[rows].reshape(len(rows), len(x)),
                        np.eye(len(x))[np.abs(lam_x) > threshold]])
    directions = linalg.null_space(active) if len(active) else np.eye(len(x))
    if directions.shape[1] == 0:
        return []  # a vertex: the active constraints fix every variable
    curvature, vectors = np.linalg.eigh(_curvature(solver, solution, directions))
    n_z = len(variables)
    flat = set()
    for value, vector in zip(curvature, vectors.T):
        direction = directions @ vector
        tunables = direction[:n_z]
        if value < FLAT_CURVATURE and np.linalg.norm(tunables) > FLAT_SHARE * np.linalg.norm(direction):
            share = np.abs(tunables) / np.linalg.norm(tunables)
            flat.update(v.name for v, c in zip(variables, share) if c > FLAT_SHARE)
    return [v.name for v in variables if v.name in flat]


def equal_optima(optima: list[tuple[int, float, np.ndarray]], best_index: int,
                 objective_scale: float,
                 variables: list[Variable]) -> list[tuple[int, dict[str, float]]]:
    """The starts whose optimum has the best start's objective, the best first, with their
    free tunables.

    ``optima`` are (start index, objective, log tunables) of every start that solved
    feasibly. Equal: objectives within SAME_OPTIMUM_TOL of the larger of |best| and
    ``objective_scale`` (the objective's size at the starts: an optimum of 0, e.g. a radial
    error, is compared against the error the starts had, not against itself).
    """
    best = next((objective for i, objective, _ in optima if i == best_index), None)
    if best is None:
        return []
    tolerance = SAME_OPTIMUM_TOL * max(abs(best), objective_scale)
    equal = sorted((i != best_index, i, z) for i, objective, z in optima
                   if abs(objective - best) <= tolerance)
    return [(i, {v.name: float(math.exp(z[k])) for k, v in enumerate(variables)})
            for _, i, z in equal]
