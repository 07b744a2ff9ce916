"""The test processes run numpy's and scipy's OpenBLAS on one thread (tests/conftest.py)."""

from __future__ import annotations

import ctypes
from pathlib import Path

import numpy  # noqa: F401  (loads numpy's OpenBLAS)
import pytest
import scipy.linalg  # noqa: F401  (loads scipy's OpenBLAS, where it bundles its own)

MAPS = Path("/proc/self/maps")
#: OpenBLAS's thread-count query under the names the numpy/scipy wheels' builds export
QUERIES = ("scipy_openblas_get_num_threads64_", "scipy_openblas_get_num_threads",
           "openblas_get_num_threads64_", "openblas_get_num_threads")


def loaded_openblas_threads() -> dict[str, int]:
    """Threads of every OpenBLAS library mapped into this process, by file name."""
    libraries = {line.split()[-1] for line in MAPS.read_text().splitlines()
                 if "openblas" in line.split()[-1].lower()}
    threads = {}
    for library in sorted(libraries):
        handle = ctypes.CDLL(library)
        for query in QUERIES:
            if hasattr(handle, query):
                threads[Path(library).name] = getattr(handle, query)()
                break
    return threads


@pytest.mark.skipif(not MAPS.exists(), reason="lists the loaded libraries from /proc (Linux)")
def test_every_loaded_openblas_runs_one_thread():
    threads = loaded_openblas_threads()
    if not threads:
        pytest.skip("numpy and scipy are not linked against an OpenBLAS that says its threads")
    assert threads == dict.fromkeys(threads, 1)
