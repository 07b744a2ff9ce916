#!/usr/bin/env python
"""A batch spec's phases with CasADi's Functions compiled to C: a prototype, measured.

``batch_profile.py`` (same specs, warm-up and phase table) with, as asked:

- ``--jit``: every IPOPT solver built with ``nlpsol``'s ``jit`` (its NLP Functions and
  their derivatives generated as C and compiled by the machine's ``cc -O2`` when the
  solver is built; CasADi keeps no copy on disk, so every solver build compiles again, in
  a child process whose CPU ``process_time`` does not count: the script prints it);
- ``--maps structure``: every replayed Function of the tuned design's evaluation
  (``frequency.Mapped``: the peaks' and crossings' rows, the jets, the golden and
  bisection folds) compiled once per Function, the row maps made over the compiled one;
  ``--maps rows``: every evaluation buffer's Function (``frequency.Buffered``: each row
  length's map itself) compiled, one library per row length.

Compiled libraries are cached in ``--cache`` by the SHA-256 of the generated source (the
first run fills it; run again to measure warm), written under a temporary name and
renamed. The C generation and loading of each Function is counted in the phases. With
``--out DIR`` the specs are solved once more afterwards and their result files written
there, for ``batch_throughput.compare_results`` against a run without compilation.

Two processes started together (one with the options, one without) see the same machine;
the untouched validation phase tells how far their speeds differed.

    .venv/bin/python benchmarks/compiled_batch.py --specs 120 --jit --maps structure &
    .venv/bin/python benchmarks/compiled_batch.py --specs 120; wait
"""

from __future__ import annotations

import os

for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import argparse  # noqa: E402
import hashlib  # noqa: E402
import json  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import threading  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))

import batch_profile  # noqa: E402  (puts the measured tree first on sys.path)
import casadi as ca  # noqa: E402
from batch_throughput import generate  # noqa: E402

import feedtune.loops.frequency as frequency  # noqa: E402
import feedtune.tuner.cache as cache  # noqa: E402

STATS = {"generate and load CPU s": 0.0, "compiled": 0, "compiler CPU s": 0.0, "loaded": 0,
         "not compiled": 0}
_compiled: dict[int, tuple] = {}  # id(Function) → (the Function, its compiled stand-in)


def compiled(fn: ca.Function, directory: Path) -> ca.Function:
    """``fn`` generated as C, compiled (or found in ``directory`` by its source's hash) and
    loaded; ``fn`` itself when it has no C form or the compiler fails."""
    kept = _compiled.get(id(fn))
    if kept is not None:
        return kept[1]
    started = time.process_time()
    try:
        with tempfile.TemporaryDirectory() as scratch:
            generator = ca.CodeGenerator("f.c", {"with_header": False})
            generator.add(fn)
            generator.generate(scratch + "/")
            source = Path(scratch, "f.c").read_bytes()
        if b"#error" in source:  # e.g. "SymbolicQr does not support code generation"
            raise RuntimeError("no C form")
        digest = hashlib.sha256(source).hexdigest()[:32]
        library = directory / f"{digest}.so"
        if not library.exists():
            with tempfile.TemporaryDirectory(dir=directory) as scratch:
                c_file, built = Path(scratch, "f.c"), Path(scratch, "f.so")
                c_file.write_bytes(source)
                before = os.times()
                subprocess.run(["cc", "-O2", "-shared", "-fPIC", str(c_file), "-o", str(built),
                                "-lm"], check=True, capture_output=True)
                after = os.times()
                STATS["compiler CPU s"] += (after.children_user + after.children_system
                                            - before.children_user - before.children_system)
                os.replace(built, library)
            STATS["compiled"] += 1
        stand_in = ca.external(fn.name(), str(library))
        STATS["loaded"] += 1
    except (RuntimeError, subprocess.CalledProcessError):
        stand_in = fn
        STATS["not compiled"] += 1
    STATS["generate and load CPU s"] += time.process_time() - started
    _compiled[id(fn)] = (fn, stand_in)
    return stand_in


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--specs", type=int, default=120)
    parser.add_argument("--jit", action="store_true", help="compile every IPOPT solver's NLP")
    parser.add_argument("--maps", choices=("none", "structure", "rows"), default="none")
    parser.add_argument("--cache", type=Path,
                        default=Path(tempfile.gettempdir()) / "feedtune-compiled-batch")
    parser.add_argument("--out", type=Path, help="write the specs' result files here")
    args = parser.parse_args(argv)
    args.cache = args.cache.resolve()
    args.cache.mkdir(parents=True, exist_ok=True)
    args.out = args.out.resolve() if args.out else None

    if args.jit:
        os.chdir(tempfile.mkdtemp(prefix="feedtune-jit-"))  # where CasADi's jit writes its C
        make_solver = cache.make_solver
        jit = {"jit": True, "compiler": "shell", "jit_cleanup": True,
               "jit_options": {"compiler": "cc", "flags": ["-O2"], "verbose": False}}

        def compiled_solver(nlp, options, expand):
            before = os.times()
            try:
                return make_solver(nlp, {**options, **jit}, expand)
            finally:
                after = os.times()
                STATS["compiler CPU s"] += (after.children_user + after.children_system
                                            - before.children_user - before.children_system)

        cache.make_solver = compiled_solver
    buffered = frequency.Buffered.__init__
    if args.maps == "rows":
        def compiled_buffer(self, fn):
            buffered(self, compiled(fn, args.cache))

        frequency.Buffered.__init__ = compiled_buffer
    elif args.maps == "structure":
        def row(self, size):
            key = (threading.get_ident(), size)
            found = self._rows.get(key)
            if found is None:
                fn = compiled(self.fn, args.cache)
                shared = [False] + [True] * (fn.n_in() - 1)
                found = self._rows[key] = frequency.Buffered(
                    fn if size == 1 else fn.map(size, shared, [False] * fn.n_out()))
            return found

        frequency.Mapped._row = row
    before = dict(STATS)
    clear = cache.clear_solver_cache

    def timed_from_here():  # batch_profile clears the caches right before its timed specs
        before.update(STATS)
        clear()

    batch_profile.cache.clear_solver_cache = timed_from_here
    batch_profile.main(["--specs", str(args.specs)])
    print()
    print(f"compilation (--jit {args.jit}, --maps {args.maps}), whole run: "
          + ", ".join(f"{k} {v:.2f}" if isinstance(v, float) else f"{k} {v}"
                      for k, v in STATS.items()))
    print("of it in the timed specs: "
          + ", ".join(f"{k} {STATS[k] - before[k]:.2f}" if isinstance(STATS[k], float)
                      else f"{k} {STATS[k] - before[k]}" for k in STATS))
    if args.out:
        args.out.mkdir(parents=True, exist_ok=True)
        for i, spec in enumerate(generate(max(args.specs, 300))[:args.specs]):
            outcome = batch_profile.job.solve(json.dumps(spec).encode())
            (args.out / f"spec{i:04d}.json").write_bytes(outcome.result or b"{}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
