"""feedtune.loops.frequency.Buffered from several threads at once: a Dask worker with
several threads runs specs that share a structure's Buffered rows, so each thread must
evaluate its own arguments. With one buffer shared by all threads, 45–55 of these 9 000
calls returned another thread's result (measured on 9df1738)."""

import sys
import threading

import casadi as ca
import numpy as np

from feedtune.loops.frequency import Buffered


def test_threads_sharing_a_buffered_function_each_get_their_own_result():
    x = ca.SX.sym("x", 3)
    buffered = Buffered(ca.Function("f", [x], [ca.sumsqr(x) * x]))
    wrong = []

    def work(k: float):
        for i in range(3000):
            v = np.array([k, float(i), 1.0])
            if not np.array_equal(buffered(v)[0], (v @ v) * v):  # same operations: same bits
                wrong.append((k, i))

    interval = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)  # switch threads as often as the interpreter can
    try:
        threads = [threading.Thread(target=work, args=(k,)) for k in (1.0, 2.0, 3.0)]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
    finally:
        sys.setswitchinterval(interval)
    assert wrong == []
