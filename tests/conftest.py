"""Settings of the whole test suite, applied before any test module loads numpy or scipy.

One BLAS thread per test process, as the ``feedtune`` command itself runs
(:func:`feedtune.__main__.pin_blas_threads`): the suite's many small ``expm``, eigenvalue and
solve calls ran 5× slower with OpenBLAS's default thread per core (issue 15), and worse with
one test worker per core (pytest-xdist, ``addopts`` in pyproject.toml).

feedtune's bytecode is written once, before the tests start (:func:`pytest_configure`): the
suite starts many ``python -m feedtune`` processes and batch workers, and with
``pip install -e`` nothing else writes it when ``PYTHONDONTWRITEBYTECODE`` is set (as the
tests set it for their subprocesses, and as many CI images do), so each of them compiled
feedtune's sources again (≈ 0.1 s of CPU a process; issue 15). So is the bytecode of the
libraries the tests import (LIBRARIES, tests/bytecode_cache.py): the README's test command
installs without ``--compile-bytecode``, which compiled all ≈ 5 300 modules of the
environment (≈ 22 s of CPU) for the ≈ 1 700 that the tests import. So is pytest's
assertion-rewritten code of the test modules and the plugins' modules
(tests/rewrite_cache.py), which every xdist worker rewrote for itself, and, in a fresh
clone, hypothesis's table of the characters UTF-8 encodes (tests/hypothesis_cache.py), which
every worker that drew a text computed for itself.

The cyclic garbage collector is off while a process imports the test modules and collects
their tests, and runs the tests with a larger first generation (TEST_GC_THRESHOLD): both
settings save CPU in every worker (benchmarks/README.md "Branch h-tcol",
benchmarks/suite_gc.py).

Helpers for every test (tests/README.md says when to use which):

- ``from feedtune_cli import run_cli``: ``feedtune ARGS`` through the real entry point
  (:func:`feedtune.__main__.run`) inside the test process, returning a
  ``subprocess.CompletedProcess`` (tests/feedtune_cli.py); a ``python -m feedtune`` process
  costs ≈ 1 s of CPU in imports alone.
- every test must leave SIGINT's and SIGTERM's handlers and the signal mask as it found
  them (tests/signal_guard.py; a test that does not errors at its teardown).
- the ``tuned`` fixture: ``tuned(spec)`` is ``feedtune.problem.tune(parse_spec(spec))``,
  once per spec (by its canonical JSON) per test process, for tests that only read a
  tuning's result.
"""

import compileall
import copy
import gc
import json
from pathlib import Path

import pytest

import bytecode_cache
import feedtune
import hypothesis_cache
import rewrite_cache
from feedtune.__main__ import pin_blas_threads
from signal_guard import pytest_runtest_setup, pytest_runtest_teardown  # noqa: F401

pin_blas_threads()

# The cyclic garbage collector is off while the test modules are imported and their tests
# collected (on again in pytest_collection_finish): every process (each xdist worker)
# collects the whole suite, and the imports and ≈ 6 600 items allocate enough containers to
# run the collector ≈ 700 times, its passes walking the freshly imported modules' objects
# again and again (a worker's start-up and collection 6.7–7.7 → 5.1 s of CPU,
# benchmarks/README.md "Branch h-tcol"). What collection leaves as garbage is collected by
# the first full pass.
gc.disable()

#: the collector's first-generation threshold [allocations] while the tests run (Python's
#: default 700): the tests build CasADi graphs, pydantic models and solver results by the
#: hundred thousand objects, which at 700 ran ≈ 700 young collections in 25 s of tests, each
#: walking the generation's survivors; at 10 000 ≈ 40, 0.64 → 0.12 s of collector time
#: (benchmarks/README.md "Branch h-tcol"). Garbage cycles wait a little longer; nothing a
#: test checks depends on when (the tests about freeing call ``gc.collect()`` themselves).
TEST_GC_THRESHOLD = 10_000


#: the libraries the test processes and their subprocesses import, whose bytecode the
#: process that starts the run writes (tests/bytecode_cache.py), in two groups imported side
#: by side that take about as long each (≈ 4 and ≈ 6 s of CPU when compiling, load 5); the
#: second ends with the backend the reports draw with and what a Dask scheduler and worker
#: import as they start their HTTP servers (distributed's ``http.routes``, but its proxy,
#: which logs at import), then draws one hypothesis text (tests/hypothesis_cache.py: its
#: table of UTF-8's characters, which each worker computed in a fresh clone, written once)
LIBRARIES = (
    ("feedtune.problem", "casadi", "scipy.signal", "scipy.optimize", "scipy.stats", "control",
     "cvxpy"),
    ("feedtune.cli", "pydantic", "distributed", "dask", "hypothesis", "matplotlib.pyplot",
     "matplotlib.backends.backend_agg",
     "distributed.http.scheduler.info", "distributed.http.scheduler.json",
     "distributed.http.scheduler.prometheus", "distributed.http.worker.prometheus",
     "distributed.http.health", "distributed.http.statics", "tornado.platform.asyncio",
     "importlib_metadata._adapters", hypothesis_cache.draw_a_text),
)


def pytest_configure(config):
    """Byte-compile the feedtune package in place (its ``__pycache__``, as an import or
    ``pip install`` would), the libraries the tests import (LIBRARIES,
    tests/bytecode_cache.py) and write pytest's rewritten code of the run's test modules
    (tests/rewrite_cache.py), once: in the process that starts the run, not in each xdist
    worker. A read-only installation is left as it is."""
    if hasattr(config, "workerinput"):  # an xdist worker: the controller did it
        return
    with bytecode_cache.writing(config, LIBRARIES):
        compileall.compile_dir(Path(feedtune.__file__).parent, quiet=2)
        rewrite_cache.prewrite(config, plugins=True)


#: files whose tests take far more CPU than their number suggests (≈ 50–100 s each on one
#: worker in a full run, benchmarks/README.md "Fifth round"): pytest-xdist hands files out
#: by their number of tests, largest first, which left these near the end, where one
#: worker ran one of them alone while the other had nothing left
HEAVY_FIRST = ("tests/reference/test_robust_plants.py", "tests/batch/test_batch_cli.py")


def pytest_collection_modifyitems(config, items):
    """Under ``--dist loadfile`` (with ``--no-loadscope-reorder``, pyproject.toml): the files
    in HEAVY_FIRST first, then the rest largest first (pytest-xdist's own order, by number of
    tests), each file's tests in their order. Without xdist the order is left alone."""
    if config.getoption("dist", "no") != "loadfile":
        return
    files: dict[str, list] = {}
    for item in items:
        files.setdefault(item.nodeid.split("::")[0], []).append(item)
    order = sorted(files, key=lambda name: (name not in HEAVY_FIRST, -len(files[name])))
    items[:] = [item for name in order for item in files[name]]


def pytest_sessionstart(session):
    """The garbage collector on again at once in an xdist controller, which collects
    nothing (its workers do)."""
    if session.config.pluginmanager.has_plugin("dsession"):
        gc.enable()


def pytest_collection_finish(session):
    """The garbage collector on again for the tests (off while collecting, above), its
    first generation at TEST_GC_THRESHOLD."""
    gc.set_threshold(TEST_GC_THRESHOLD, *gc.get_threshold()[1:])
    gc.enable()


@pytest.fixture(scope="session")
def tuned():
    """``tuned(spec)``: the result of tuning ``spec`` (a dict as in a spec file), tuned once
    per test process and shared by every test that asks for the same spec (same canonical
    JSON: keys sorted). The result is shared: read it, do not change it (``model_copy`` one
    to edit). For tests that only read a tuning; a test of the tuning itself (its solver,
    its starts, its reuse of a cached solver) calls ``tune`` on its own."""
    from feedtune.problem import tune
    from feedtune.schema.spec import parse_spec

    results = {}

    def get(spec: dict):
        key = json.dumps(spec, sort_keys=True)
        if key not in results:
            results[key] = tune(parse_spec(copy.deepcopy(spec)))
        return results[key]

    return get
