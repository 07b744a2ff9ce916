#!/usr/bin/env python
"""CPU of a command and of every process started below it, orphans included.

``RUSAGE_CHILDREN`` (``/usr/bin/time``, ``benchmarks/pytest_cpu.py``) counts a process
only when its parent waits for it, and a process whose parent exits first is reaped by
init: a local Dask cluster's forkserver and its worker processes, started in a child that
ends before them (``in_a_fork`` in ``tests/batch/test_batch_cli.py``), are not counted
there. Here the command runs under a child subreaper (Linux ``PR_SET_CHILD_SUBREAPER``):
every orphan below it becomes this process's child and is reaped here, so the printed
user + sys time is the whole tree's.

    .venv/bin/python benchmarks/tree_cpu.py .venv/bin/python -m pytest tests/batch -n 0
"""

import ctypes
import os
import resource
import subprocess
import sys
import time

PR_SET_CHILD_SUBREAPER = 36


def main(command: list[str]) -> int:
    if ctypes.CDLL(None, use_errno=True).prctl(PR_SET_CHILD_SUBREAPER, 1) != 0:
        print("tree_cpu: cannot become a child subreaper (Linux only)", file=sys.stderr)
        return 2
    started = time.perf_counter()
    code = subprocess.call(command)
    while True:  # the orphans, until none is left
        try:
            os.wait()
        except ChildProcessError:
            break
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    print(f"tree_cpu: exit {code}, CPU {usage.ru_utime + usage.ru_stime:.2f} s (user "
          f"{usage.ru_utime:.2f}, sys {usage.ru_stime:.2f}), wall "
          f"{time.perf_counter() - started:.1f} s, load {os.getloadavg()[0]:.1f} at the end",
          file=sys.stderr)
    return code


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
