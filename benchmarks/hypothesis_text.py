"""hypothesis strings: ``st.text()``'s default alphabet against tests/hypothesis_text.py's
UTF8, in fresh processes with an empty ``.hypothesis`` (a fresh clone's test worker).

``st.text()`` draws from ``st.characters(codec="utf-8")``, whose set hypothesis finds by
encoding every code point once a process (then keeps it in ``.hypothesis/``); UTF8 is the
same set named by category (all but the surrogates, Cs). Each round starts one process for
each alphabet, alternating, in a new empty directory, that imports hypothesis, draws
``--examples`` examples from each seed of the suite's string strategies (the batch names'
list of texts, the spec tests' JSON values) and prints a digest of what it drew. Prints the
CPU of each process (user + sys) and whether the two drew the same examples::

    .venv/bin/python benchmarks/hypothesis_text.py --rounds 5
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

CHILD = r"""
import hashlib, sys
sys.path.insert(0, {tests!r})
from hypothesis import given, seed, settings, strategies as st
from hypothesis_text import UTF8

alphabet = None if {which!r} == "st.text" else UTF8


def text(**sizes):
    return st.text(**sizes) if alphabet is None else st.text(alphabet, **sizes)


names = st.lists(st.one_of(text(min_size=0, max_size=150), st.sampled_from(["summary", "a"])),
                 min_size=1, max_size=30)
json_values = st.recursive(
    st.none() | st.booleans() | st.integers(-10**6, 10**6) | text(max_size=8),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(text(max_size=6), inner,
                                                                max_size=4), max_leaves=12)
drawn = []
for strategy in (names, json_values, text()):
    for s in range({seeds}):
        @seed(s)
        @settings(database=None, max_examples={examples}, deadline=None)
        @given(strategy)
        def collect(value):
            drawn.append(repr(value))

        collect()
print(hashlib.sha256("\n".join(drawn).encode()).hexdigest(), len(drawn))
"""


def _run(which: str, examples: int, seeds: int) -> tuple[float, str]:
    """(CPU s of the child, its digest) in a new empty working directory."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    with tempfile.TemporaryDirectory() as cwd:
        out = subprocess.run(
            [sys.executable, "-c", CHILD.format(tests=str(REPO / "tests"), which=which,
                                                examples=examples, seeds=seeds)],
            cwd=cwd, capture_output=True, text=True, check=True,
            env={**os.environ, "PYTHONDONTWRITEBYTECODE": "1"}).stdout.strip()
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return cpu, out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--examples", type=int, default=100)
    parser.add_argument("--seeds", type=int, default=3)
    args = parser.parse_args()
    times = {"st.text": [], "UTF8": []}
    digests = {"st.text": set(), "UTF8": set()}
    for r in range(args.rounds):
        order = ("st.text", "UTF8") if r % 2 == 0 else ("UTF8", "st.text")
        for which in order:
            cpu, digest = _run(which, args.examples, args.seeds)
            times[which].append(cpu)
            digests[which].add(digest)
        print(f"round {r + 1}: st.text {times['st.text'][-1]:.3f} s, "
              f"UTF8 {times['UTF8'][-1]:.3f} s (CPU of the process)")
    old, new = statistics.median(times["st.text"]), statistics.median(times["UTF8"])
    print(f"median CPU a process: st.text {old:.3f} s, UTF8 {new:.3f} s, "
          f"ratio {new / old:.2f}, saved {old - new:.3f} s")
    same = digests["st.text"] == digests["UTF8"] and len(digests["UTF8"]) == 1
    print(f"the same examples drawn from every seed: {same} ({next(iter(digests['UTF8']))})")


if __name__ == "__main__":
    main()
