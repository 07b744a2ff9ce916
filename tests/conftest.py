"""Settings of the whole test suite, applied before any test module loads numpy or scipy.

One BLAS thread per test process, as the ``feedtune`` command itself runs
(:func:`feedtune.__main__.pin_blas_threads`): the suite's many small ``expm``, eigenvalue and
solve calls ran 5× slower with OpenBLAS's default thread per core (issue 15), and worse with
one test worker per core (pytest-xdist, ``addopts`` in pyproject.toml).
"""

from feedtune.__main__ import pin_blas_threads

pin_blas_threads()
