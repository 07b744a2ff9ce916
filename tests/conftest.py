"""Settings of the whole test suite, applied before any test module loads numpy or scipy.

One BLAS thread per test process, as the ``feedtune`` command itself runs
(:func:`feedtune.__main__.pin_blas_threads`): the suite's many small ``expm``, eigenvalue and
solve calls ran 5× slower with OpenBLAS's default thread per core (issue 15), and worse with
one test worker per core (pytest-xdist, ``addopts`` in pyproject.toml).

feedtune's bytecode is written once, before the tests start (:func:`pytest_configure`): the
suite starts many ``python -m feedtune`` processes and batch workers, and with
``pip install -e`` nothing else writes it when ``PYTHONDONTWRITEBYTECODE`` is set (as the
tests set it for their subprocesses, and as many CI images do), so each of them compiled
feedtune's sources again (≈ 0.1 s of CPU a process; issue 15).
"""

import compileall
from pathlib import Path

import feedtune
from feedtune.__main__ import pin_blas_threads

pin_blas_threads()


def pytest_configure(config):
    """Byte-compile the feedtune package in place (its ``__pycache__``, as an import or
    ``pip install`` would), once: in the process that starts the run, not in each xdist
    worker. A read-only installation is left as it is."""
    if hasattr(config, "workerinput"):  # an xdist worker: the controller did it
        return
    compileall.compile_dir(Path(feedtune.__file__).parent, quiet=2)
