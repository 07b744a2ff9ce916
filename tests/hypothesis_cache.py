"""Hypothesis's table of the characters UTF-8 encodes, written once by the process that
starts the run, before the xdist workers draw their first text.

``st.text()`` draws from ``st.characters(codec="utf-8")``: the first such strategy in a
process needs the code points UTF-8 encodes, which hypothesis finds by encoding each of
the 1 114 112 code points (≈ 1.5 s of CPU) and keeps in its storage directory
(``.hypothesis`` in the working directory). A fresh clone (the README's test command, CI)
has none, so every worker that drew a text (the property tests, the unit tests of
untrusted input) computed it again (benchmarks/README.md, "Branch h-tunit3").
:func:`draw_a_text` is called by the process that imports hypothesis to write its bytecode
(``LIBRARIES`` in tests/conftest.py, tests/bytecode_cache.py: a fresh clone's first run with
``PYTHONDONTWRITEBYTECODE``, as CI), while the run starts: hypothesis writes the table
(atomically, as a worker would) and the workers read it (≈ 0.01 s); the draw also writes
hypothesis's cache of the local constants of the few feedtune modules that process has
loaded. Both are what each worker would have computed, so every drawn example is
unchanged; a worker that draws before they are written computes them itself, as before.
"""

from __future__ import annotations


def draw_a_text() -> None:
    """Draw one text, without a database (nothing is stored as an example)."""
    from hypothesis import find, settings
    from hypothesis import strategies as st

    find(st.text(), lambda text: True, settings=settings(database=None))
