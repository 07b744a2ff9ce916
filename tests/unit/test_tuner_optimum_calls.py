"""feedtune.tuner.optimum's derivative calls: the NLP's Jacobian and Hessian taken from the
solver once and evaluated through their buffers (feedtune.tuner.calls) give what a call with
DMs gives, to the bit, and so the same flat tunables (issue 15's batch, branch h-bst5)."""

import gc
import weakref

import casadi as ca
import numpy as np

from feedtune.tuner import optimum
from feedtune.tuner.optimum import Solution, flat_tunables
from feedtune.tuner.types import Variable


def _solved(objective):
    """IPOPT (exact Hessian) on ``objective(z)`` of two log tunables, z0 + z1 ≥ 1, and its
    Solution."""
    z, p = ca.MX.sym("z", 2), ca.MX.sym("p")
    solver = ca.nlpsol("flat", "ipopt", {"x": z, "p": p, "f": objective(z, p),
                                         "g": z[0] + z[1]},
                       {"ipopt": {"print_level": 0, "sb": "yes"}, "print_time": False})
    lbg, ubg = np.array([1.0]), np.array([np.inf])
    out = solver(x0=[0.3, 0.2], p=2.0, lbx=-5, ubx=5, lbg=lbg, ubg=ubg)
    solution = Solution(np.asarray(out["x"].full()).ravel(), np.array([2.0]),
                        np.asarray(out["lam_g"].full()).ravel(),
                        np.asarray(out["lam_x"].full()).ravel(), lbg, ubg)
    return solver, solution


VARIABLES = [Variable("a", 0.1, 10.0), Variable("b", 0.1, 10.0)]


def test_the_derivatives_are_the_dm_calls_to_the_bit():
    solver, s = _solved(lambda z, p: (z[0] - p) ** 2 + ca.exp(z[1]) * z[0] ** 2)
    for name, inputs in (("nlp_jac_g", (s.x, s.p)), ("nlp_hess_l", (s.x, s.p, 1.0, s.lam_g))):
        theirs = solver.get_function(name)(*inputs)
        ours = optimum._derivative(solver, name)(*inputs)
        theirs = [theirs] if isinstance(theirs, ca.DM) else theirs
        ours = [ours] if isinstance(ours, np.ndarray) else ours
        assert len(ours) == len(theirs)
        for a, b in zip(ours, theirs):
            np.testing.assert_array_equal(a, b.full())
    # one call per solver and name, taken once
    assert optimum._derivative(solver, "nlp_jac_g") is optimum._derivative(solver, "nlp_jac_g")


def test_flat_and_curved_optima_are_told_apart_through_the_buffers():
    # the objective depends on z0 + z1 only: flat along (1, -1), and the constraint's
    # multiplier is 0 at the interior optimum z0 + z1 = 2 > 1
    flat_solver, flat = _solved(lambda z, p: (z[0] + z[1] - p) ** 2)
    assert flat_tunables(flat_solver, flat, VARIABLES) == ["a", "b"]
    curved_solver, curved = _solved(lambda z, p: (z[0] - p) ** 2 + (z[1] - p) ** 2)
    assert flat_tunables(curved_solver, curved, VARIABLES) == []


def test_the_derivatives_do_not_keep_their_solver():
    solver, s = _solved(lambda z, p: (z[0] - p) ** 2 + (z[1] - 1) ** 2)
    optimum._derivative(solver, "nlp_jac_g")(s.x, s.p)
    gone = weakref.ref(solver)
    del solver
    if gone() is not None:  # a full collection of the worker's heap only where
        gc.collect()  # reference counting left it
    assert gone() is None
