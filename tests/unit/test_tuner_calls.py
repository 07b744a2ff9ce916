"""feedtune.tuner.calls: Functions evaluated at numbers through their evaluation buffers give
what a call with DMs gives, to the bit (issue 15's batch: ≈ 20 µs an argument saved)."""

import threading

import casadi as ca
import numpy as np
import pytest

from feedtune.tuner.calls import NumericCall, numeric


def _function():
    """Two inputs, a dense column, a matrix with structural zeros and a scalar out."""
    z, p = ca.MX.sym("z", 2), ca.MX.sym("p", 3)
    matrix = ca.vertcat(ca.horzcat(ca.MX(1, 1), z[0] * p[1]), ca.horzcat(ca.sin(z[1]), ca.MX(1, 1)))
    return ca.Function("f", [z, p], [ca.vertcat(z * p[0], ca.exp(z[1] / 3)), matrix,
                                     ca.dot(z, p[1:])], ["z", "p"], ["column", "matrix", "dot"])


def test_outputs_are_the_dm_calls_to_the_bit_zeros_where_the_sparsity_has_none():
    f = _function()
    assert not f.sparsity_out(1).is_dense()  # the case that needs scattering
    z, p = np.array([0.3, -1.7]), np.array([1.1, 2.0 / 3.0, np.pi])
    ours = NumericCall(f)(z, p)
    theirs = f(z, p)
    for a, b in zip(ours, theirs):
        np.testing.assert_array_equal(a, b.full())
        assert a.shape == b.full().shape
    named = NumericCall(f).named(p=p, z=z)
    assert list(named) == ["column", "matrix", "dot"]
    np.testing.assert_array_equal(named["matrix"], theirs[1].full())


def test_one_output_comes_alone_and_left_out_inputs_take_their_defaults():
    x, y = ca.MX.sym("x"), ca.MX.sym("y")
    f = ca.Function("g", [x, y], [x + 2 * y], ["x", "y"], ["r"], {"default_in": [0.0, 5.0]})
    call = NumericCall(f)
    assert call(1.0, 3.0).shape == (1, 1) and float(call(1.0, 3.0)[0, 0]) == 7.0
    assert float(call.named(x=1.0)["r"][0, 0]) == float(f(x=1.0)["r"]) == 11.0
    with pytest.raises(ValueError, match="no input"):
        call.named(w=1.0)


def test_a_sparse_input_is_refused():
    x = ca.MX.sym("x", ca.Sparsity.diag(2))
    with pytest.raises(ValueError, match="not dense"):
        NumericCall(ca.Function("h", [x], [ca.sum1(ca.sum2(x))]))


def test_an_ipopt_solve_is_the_dm_calls_iterates_multipliers_and_statistics():
    w, p = ca.MX.sym("w", 2), ca.MX.sym("p")
    nlp = {"x": w, "p": p, "f": (w[0] - p) ** 2 + 10 * (w[1] - w[0] ** 2) ** 2,
           "g": ca.vertcat(w[0] + w[1], w[0] * w[1])}
    solver = ca.nlpsol("s", "ipopt", nlp, {"ipopt": {"print_level": 0, "sb": "yes"},
                                           "print_time": False, "error_on_fail": False})
    inputs = dict(x0=[-1.0, 2.0], p=1.5, lbx=[-5, -5], ubx=[5, 5], lbg=[-np.inf, 0.5],
                  ubg=[2.0, np.inf])
    theirs = solver(**inputs)
    stats = solver.stats()
    call = NumericCall(solver, check=False)
    ours = call.named(**inputs)
    for name in ("x", "f", "g", "lam_x", "lam_g"):
        np.testing.assert_array_equal(ours[name], theirs[name].full())
    assert call.stats()["iter_count"] == stats["iter_count"] > 0
    assert call.stats()["return_status"] == stats["return_status"]
    # warm multipliers by name, as the tuner's exchange rounds pass them
    warm = dict(inputs, lam_g0=ours["lam_g"], lam_x0=ours["lam_x"])
    np.testing.assert_array_equal(call.named(**warm)["x"], solver(**warm)["x"].full())


def test_each_thread_evaluates_in_its_own_buffer():
    f = _function()
    call = numeric(f)
    assert numeric(f) is call  # one per Function and process
    failures = []

    def run(offset):
        for i in range(300):
            z = np.array([offset + i, 1.0])
            column = call(z, np.array([2.0, 1.0, 1.0]))[0]
            if column[0, 0] != 2.0 * (offset + i):
                failures.append((offset, i, column[0, 0]))

    threads = [threading.Thread(target=run, args=(k * 1000.0,)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert failures == []


def test_a_numeric_call_does_not_keep_its_function_alive():
    """A cached solver dropped from the cache is freed with its numeric call (each keeps
    an IPOPT solver's memory)."""
    import gc
    import weakref

    f = _function()
    call = weakref.ref(numeric(f))
    function = weakref.ref(f)
    del f
    if function() is not None or call() is not None:  # a full collection of the
        gc.collect()  # worker's heap only where reference counting left them
    assert function() is None and call() is None


def _interrupted(solve) -> str:
    """The return status of ``solve()`` when a KeyboardInterrupt is raised 0.2 s into it,
    as Ctrl-C raises one (by SIGALRM here: pytest's SIGINT is left alone)."""
    import signal

    solving = [True]

    def interrupt(signum, frame):
        if solving[0]:  # never outside the solve: a late alarm does nothing
            raise KeyboardInterrupt

    previous = signal.signal(signal.SIGALRM, interrupt)
    try:
        signal.setitimer(signal.ITIMER_REAL, 0.2)
        status = solve()
    finally:
        solving[0] = False
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
    return status


def test_an_interrupted_solve_ends_as_a_dm_calls_does():
    """CasADi's interrupt check inside IPOPT runs the signal handler and catches its
    KeyboardInterrupt: the solve returns NonIpopt_Exception_Thrown. The DM call clears the
    exception; the buffer's call would leave it set (a SystemError): both return alike."""
    n = 2000
    x = ca.MX.sym("x", n)
    solver = ca.nlpsol("slow", "ipopt", {"x": x, "f": ca.sumsqr(x[1:] - x[:-1] ** 2)
                                         + ca.sumsqr(1 - x)},
                       {"ipopt": {"print_level": 0, "sb": "yes", "tol": 1e-300,
                                  "acceptable_iter": 0, "max_iter": 100000,
                                  "max_wall_time": 20.0,
                                  "hessian_approximation": "limited-memory"},
                        "print_time": False, "error_on_fail": False})
    x0 = np.full(n, -1.2)

    def with_dms():
        solver(x0=x0)
        return solver.stats()["return_status"]

    def buffered():
        call = NumericCall(solver, check=False)
        call.named(x0=x0)
        return call.stats()["return_status"]

    assert _interrupted(with_dms) == _interrupted(buffered) == "NonIpopt_Exception_Thrown"


def test_an_output_without_nonzeros_is_its_zeros():
    """A Jacobian of rows that do not depend on the variables has no nonzeros at all."""
    x, p = ca.MX.sym("x", 2), ca.MX.sym("p")
    f = ca.Function("j", [x, p], [ca.jacobian(ca.vertcat(p, 2 * p), x), x * p])
    assert f.sparsity_out(0).nnz() == 0
    ours = NumericCall(f)([1.0, 2.0], 3.0)
    np.testing.assert_array_equal(ours[0], np.zeros((2, 2)))
    np.testing.assert_array_equal(ours[1], f([1.0, 2.0], 3.0)[1].full())
