#!/usr/bin/env python
"""How much of a batch spec's CPU is CasADi's virtual machine, and what compiled C would save.

Runs ``feedtune.batch.job.solve`` on the first ``--specs`` specs of
``benchmarks/batch_throughput.py``'s generated set (after one untimed solve of each kind,
one BLAS thread, as ``batch_profile.py`` does) and records, per phase of a spec
(``Problem.__init__``, the starts, the exact evaluation + reports, validation):

- every numeric call of a CasADi Function from Python (``Function.call`` with numbers, and
  the replayed Functions' buffers, ``frequency.Buffered``): the CPU of the call, its
  Function and the first call's inputs;
- ``ca.evalf`` (an MX graph of constants evaluated: a Function built and called);
- inside IPOPT, the CPU of its callbacks (``solver.stats()``'s ``t_proc_nlp_*``) against
  the whole solve (``t_proc_total``).

Then, for the Functions that took the most time, it generates C for each
(``Function.generate``), compiles it with the machine's compiler (``cc -O2 -shared -fPIC``)
and times the Function's virtual machine against the compiled code on the recorded inputs,
both through an evaluation buffer (``Function.buffer``: no DM conversion, so the
difference is the evaluation itself); the same for the IPOPT solver's oracle Functions
(``nlp_f``, ``nlp_g``, ``nlp_grad_f``, ``nlp_jac_g``, ``nlp_hess_l``) at their recorded
point. It prints the saving these ratios give per spec: what compiled code can save at
most, whatever Python and call overhead stays.

    .venv/bin/python benchmarks/compiled_share.py --specs 120
"""

from __future__ import annotations

import os

for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import argparse  # noqa: E402
import functools  # noqa: E402
import json  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from collections import defaultdict  # noqa: E402
from pathlib import Path  # noqa: E402

TREE = Path(os.environ.get("FEEDTUNE_BENCH_TREE") or Path(__file__).resolve().parents[1])
sys.path.insert(0, str(TREE))
sys.path.insert(1, str(Path(__file__).resolve().parent))

import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402
from batch_throughput import generate, one_spec_per_structure  # noqa: E402

import feedtune.batch.job as job  # noqa: E402
import feedtune.loops.frequency as frequency  # noqa: E402
import feedtune.problem as problem  # noqa: E402
import feedtune.tuner.nlp as nlp  # noqa: E402

PHASES = [("Problem.__init__", nlp.Problem, "__init__"),
          ("starts", nlp.Problem, "_solve_from"),
          ("evaluation + reports", nlp.Problem, "_evaluate_numeric"),
          ("validation", problem, "_validation")]

_phase = ["other"]
PHASE_CPU: dict[str, float] = defaultdict(float)
#: (phase, kind) → [CPU s, calls]; kind: "call", "buffer", "evalf", "ipopt callbacks", "ipopt"
SHARE: dict[tuple, list] = defaultdict(lambda: [0.0, 0])
#: id(Function) → [phase, Function, CPU s, calls, first inputs (flat arrays)]
FUNCTIONS: dict[int, list] = {}
IPOPT_STATS: list = []  # (phase, solver, stats, x0, p)
_depth = [0]
_spec = [0]  # the index of the spec being solved


def _phased(label, fn):
    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        previous, _phase[0] = _phase[0], label
        started = time.process_time()
        try:
            return fn(*args, **kwargs)
        finally:
            PHASE_CPU[label] += time.process_time() - started
            _phase[0] = previous
    return wrapper


def _numeric(args) -> bool:
    values = args.values() if isinstance(args, dict) else args
    return not any(isinstance(a, (ca.MX, ca.SX)) for a in values)


def _flat(args, fn) -> list | None:
    try:
        if isinstance(args, dict):
            args = [args.get(name, 0) for name in fn.name_in()]
        return [np.asarray(ca.DM(a) if not isinstance(a, np.ndarray) else a,
                           dtype=float).ravel(order="F") for a in args]
    except Exception:  # noqa: BLE001 (a measurement: skip what cannot be replayed)
        return None


_original_call = ca.Function.call


def _call(self, *args, **kwargs):
    if _depth[0] or not args or not _numeric(args[0]):
        return _original_call(self, *args, **kwargs)
    _depth[0] += 1
    started = time.process_time()
    try:
        return _original_call(self, *args, **kwargs)
    finally:
        spent = time.process_time() - started
        _depth[0] -= 1
        phase = _phase[0]
        if self.class_name() == "IpoptInterface":
            stats = self.stats()
            callbacks = sum(v for k, v in stats.items() if k.startswith("t_proc_nlp_"))
            SHARE[phase, "ipopt solve"][0] += spent
            SHARE[phase, "ipopt solve"][1] += 1
            SHARE[phase, "ipopt callbacks"][0] += callbacks
            SHARE[phase, "ipopt callbacks"][1] += sum(
                v for k, v in stats.items() if k.startswith("n_call_nlp_"))
            if len(IPOPT_STATS) < 400:
                x = args[0]
                IPOPT_STATS.append((self, {k: v for k, v in stats.items()
                                           if k.startswith(("t_proc_nlp_", "n_call_nlp_"))},
                                    np.asarray(x["x0"], float).ravel(),
                                    np.asarray(x["p"], float).ravel()))
        else:
            SHARE[phase, "call"][0] += spent
            SHARE[phase, "call"][1] += 1
            entry = FUNCTIONS.get(id(self))
            if entry is None:
                entry = FUNCTIONS[id(self)] = [phase, self, 0.0, 0, _flat(args[0], self), set()]
            entry[2] += spent
            entry[3] += 1
            entry[5].add(_spec[0])


_original_buffered = frequency.Buffered.__init__
_original_buffered_call = frequency.Buffered.__call__


def _buffered_init(self, fn):
    _original_buffered(self, fn)
    self._measured_fn = fn


def _buffered_call(self, *args):
    started = time.process_time()
    try:
        return _original_buffered_call(self, *args)
    finally:
        spent = time.process_time() - started
        phase = _phase[0]
        SHARE[phase, "buffer"][0] += spent
        SHARE[phase, "buffer"][1] += 1
        entry = FUNCTIONS.get(id(self._measured_fn))
        if entry is None:
            entry = FUNCTIONS[id(self._measured_fn)] = [
                phase, self._measured_fn, 0.0, 0, [np.array(a, float).copy() for a in self._args],
                set()]
        entry[2] += spent
        entry[3] += 1
        entry[5].add(_spec[0])


_original_evalf = ca.evalf


def _evalf(x):
    started = time.process_time()
    try:
        return _original_evalf(x)
    finally:
        SHARE[_phase[0], "evalf"][0] += time.process_time() - started
        SHARE[_phase[0], "evalf"][1] += 1


def _compiled(fn: ca.Function, workdir: Path):
    """``fn`` as generated C, compiled and loaded (``casadi.external``), with the compile
    CPU (s), or (None, error)."""
    name = f"f{abs(hash((fn.name(), id(fn))))}"
    source = workdir / f"{name}.c"
    library = workdir / f"{name}.so"
    gen = ca.CodeGenerator(f"{name}.c", {"with_header": False})
    gen.add(fn)
    gen.generate(str(workdir) + "/")
    started = os.times()
    result = subprocess.run(["cc", "-O2", "-shared", "-fPIC", str(source), "-o", str(library),
                             "-lm"], capture_output=True, text=True)
    ended = os.times()
    compile_cpu = (ended.children_user + ended.children_system
                   - started.children_user - started.children_system)
    if result.returncode != 0:
        errors = [line.strip() for line in result.stderr.splitlines() if "#error" in line]
        return None, (errors or [result.stderr.strip()[-200:]])[0]
    return ca.external(fn.name(), str(library)), compile_cpu


def _time_buffer(fn: ca.Function, inputs: list, repeat: int) -> float:
    """CPU s a call of ``fn`` at ``inputs`` through an evaluation buffer."""
    buffer, trigger = fn.buffer()
    args = [np.ascontiguousarray(np.resize(a, fn.nnz_in(i)), float) if a.size != fn.nnz_in(i)
            else np.ascontiguousarray(a, float) for i, a in enumerate(inputs)]
    results = [np.zeros(fn.nnz_out(i)) for i in range(fn.n_out())]
    for i, a in enumerate(args):
        buffer.set_arg(i, memoryview(a))
    for i, r in enumerate(results):
        buffer.set_res(i, memoryview(r))
    trigger()
    best = float("inf")
    for _ in range(3):
        started = time.process_time()
        for _ in range(repeat):
            trigger()
        best = min(best, (time.process_time() - started) / repeat)
    return best, results


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--specs", type=int, default=120)
    parser.add_argument("--top", type=int, default=25, help="Functions compiled and timed")
    args = parser.parse_args(argv)
    specs = generate(max(args.specs, 300))
    frequency.Buffered.__init__ = _buffered_init  # before the warm-up, which makes most
    for spec in one_spec_per_structure(specs):
        job.solve(json.dumps(spec).encode())
    for label, owner, name in PHASES:
        setattr(owner, name, _phased(label, getattr(owner, name)))
    ca.Function.call = _call
    frequency.Buffered.__call__ = _buffered_call
    ca.evalf = _evalf
    data = [json.dumps(s).encode() for s in specs[:args.specs]]
    load = os.getloadavg()[0]
    cpu = time.process_time()
    statuses = defaultdict(int)
    for _spec[0], d in enumerate(data):
        outcome = job.solve(d)
        statuses[f"{outcome.status}: {str(outcome.message)[:100]}"] += 1
    cpu = time.process_time() - cpu
    ca.Function.call = _original_call
    ca.evalf = _original_evalf
    n = len(data)
    print(f"{n} specs, {cpu / n * 1e3:.1f} ms/spec CPU (instrumented), load {load:.2f} → "
          f"{os.getloadavg()[0]:.2f}")
    print("outcomes:", dict(statuses))
    print()
    print("| phase | CPU ms/spec | numeric Function calls ms (calls) | buffers ms (calls) "
          "| evalf ms (calls) | IPOPT solves ms (solves) | of it callbacks ms (calls) |")
    print("|---|---|---|---|---|---|---|")
    for label, _, _ in PHASES:
        cells = []
        for kind in ("call", "buffer", "evalf", "ipopt solve", "ipopt callbacks"):
            spent, calls = SHARE.get((label, kind), (0.0, 0))
            cells.append(f"{spent / n * 1e3:.2f} ({calls / n:.1f})")
        print(f"| {label} | {PHASE_CPU[label] / n * 1e3:.2f} | " + " | ".join(cells) + " |")

    # VM against compiled code, Function by Function
    ranked = sorted(FUNCTIONS.values(), key=lambda e: -e[2])
    print()
    print("time in Functions by how many of the specs called each (a Function made for one "
          "spec cannot repay its compilation):")
    for low, high in ((1, 1), (2, 9), (10, 10 ** 9)):
        chosen = [e for e in ranked if low <= len(e[5]) <= high]
        by_phase = defaultdict(float)
        for e in chosen:
            by_phase[e[0]] += e[2]
        print(f"- called in {low}–{high} specs: {len(chosen)} Functions, "
              + ", ".join(f"{k} {v / n * 1e3:.2f} ms/spec" for k, v in by_phase.items()))
    ranked = [e for e in ranked if len(e[5]) >= 2]
    print()
    print(f"{len(FUNCTIONS)} distinct Functions called with numbers; the {args.top} costliest:")
    print()
    print("| phase | Function | SX/MX | instructions | calls/spec | ms/spec (Python) | VM µs "
          "| compiled µs | compile s | saving ms/spec |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    saving: dict[str, float] = defaultdict(float)
    workdir = Path(tempfile.mkdtemp(prefix="compiled-share-"))
    compile_total = 0.0
    ratios = []
    for phase, fn, spent, calls, inputs, _ in ranked[:args.top]:
        kind = "SX" if fn.is_a("SXFunction") else "MX" if fn.is_a("MXFunction") else fn.class_name()
        size = fn.n_instructions() if kind in ("SX", "MX") else "-"
        row = (f"| {phase} | {fn.name()} | {kind} | {size} "
               f"| {calls / n:.2f} | {spent / n * 1e3:.3f} |")
        if inputs is None:
            print(row + " - | - | - | inputs not replayable |")
            continue
        try:
            vm, vm_out = _time_buffer(fn, inputs, 200)
            compiled, compile_cpu = _compiled(fn, workdir)
            if compiled is None:
                print(row + f" {vm * 1e6:.1f} | - | - | not compiled: {compile_cpu!r} |")
                continue
            c, c_out = _time_buffer(compiled, inputs, 200)
        except Exception as error:  # noqa: BLE001
            print(row + f" - | - | - | {type(error).__name__}: {str(error)[:80]} |")
            continue
        same = all(np.array_equal(a, b, equal_nan=True) for a, b in zip(vm_out, c_out))
        saved = calls * (vm - c) / n
        saving[phase] += saved
        compile_total += compile_cpu
        ratios.append((spent, c / vm))
        print(row + f" {vm * 1e6:.1f} | {c * 1e6:.1f} | {compile_cpu:.2f} | {saved * 1e3:.3f}"
              f"{'' if same else ' (other bits)'} |")
    print()
    print("the listed Functions' saving at most, ms/spec: "
          + ", ".join(f"{k} {v * 1e3:.2f}" for k, v in saving.items())
          + f"; their compilation {compile_total:.1f} s of CPU")
    rest = sum(e[2] for e in ranked[args.top:])
    if ratios:
        weighted = sum(s * r for s, r in ratios) / sum(s for s, _ in ratios)
        print(f"the other {max(len(ranked) - args.top, 0)} Functions called in ≥ 2 specs: "
              f"{rest / n * 1e3:.2f} ms/spec in their calls; at the listed ones' time-weighted "
              f"compiled/VM ratio {weighted:.2f} (call overhead counted as VM: an upper "
              f"bound) they would save {rest * (1 - weighted) / n * 1e3:.2f} ms/spec more")

    # IPOPT's oracle Functions
    print()
    print("IPOPT callbacks: VM against compiled oracle Functions (first solves of each solver):")
    print()
    print("| solver | Function | instructions | calls/solve | VM µs | compiled µs | compile s |")
    print("|---|---|---|---|---|---|---|")
    seen = set()
    per_call: dict[tuple, tuple] = {}
    for solver, stats, x0, p in IPOPT_STATS:
        if id(solver) in seen or len(seen) >= 4:
            continue
        seen.add(id(solver))
        for name in ("nlp_f", "nlp_g", "nlp_grad_f", "nlp_jac_g", "nlp_hess_l"):
            try:
                fn = solver.get_function(name)
            except RuntimeError:
                continue
            inputs = [x0, p] + [np.ones(fn.nnz_in(i)) for i in range(2, fn.n_in())]
            try:
                vm, vm_out = _time_buffer(fn, inputs, 200)
                compiled, compile_cpu = _compiled(fn, workdir)
                c, _ = (_time_buffer(compiled, inputs, 200) if compiled is not None
                        else (float("nan"), None))
            except Exception as error:  # noqa: BLE001
                print(f"| {id(solver) % 1000} | {name} | - | - | {type(error).__name__} "
                      f"| {error} | |")
                continue
            per_call[id(solver), name] = (vm, c)
            print(f"| {id(solver) % 1000} | {name} | {fn.n_instructions()} | "
                  f"{stats.get('n_call_' + name, 0)} | {vm * 1e6:.1f} | {c * 1e6:.1f} | "
                  f"{f'{compile_cpu:.2f}' if compiled is not None else compile_cpu} |")
    # each callback's CPU inside IPOPT (its own timers), scaled by that oracle Function's
    # compiled/VM ratio (the mean over the solvers timed above)
    if per_call:
        names = {name for _, name in per_call}
        ratio = {name: float(np.mean([c / vm for (_, k), (vm, c) in per_call.items()
                                      if k == name and vm > 0 and np.isfinite(c)]))
                 for name in names}
        spent = defaultdict(float)
        calls = defaultdict(int)
        for _, stats, _, _ in IPOPT_STATS:
            for name in names:
                spent[name] += stats.get("t_proc_" + name, 0.0)
                calls[name] += stats.get("n_call_" + name, 0)
        solves = len(IPOPT_STATS)
        print()
        print(f"over the first {solves} IPOPT solves (of {SHARE['starts', 'ipopt solve'][1]}):")
        total = 0.0
        for name in sorted(names):
            saved = spent[name] * (1 - ratio[name])
            total += saved
            print(f"- {name}: {calls[name] / solves:.1f} calls a solve, "
                  f"{spent[name] / solves * 1e3:.3f} ms a solve in IPOPT's timer, "
                  f"compiled/VM {ratio[name]:.2f}: saves "
                  f"{saved / solves * 1e3:.3f} ms a solve")
        per_spec = SHARE["starts", "ipopt solve"][1] / n
        print(f"saving in the starts ≈ {total / solves * per_spec * 1e3:.2f} ms/spec "
              f"({per_spec:.2f} solves a spec)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
