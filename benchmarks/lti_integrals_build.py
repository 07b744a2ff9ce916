"""Building the sampled LTI loop's step-integral Functions, new against a git revision's
``feedtune/loops/sampled_lti_integrals.py``, side by side in one process (issue 15).

For every ``implementation: sampled`` configuration of the contract tests
(``tests/contract/contract_cases.py``), on its default box and on the factor-2 box around its
nominal point, each of IAE, ISE and ITAE: the CPU of ``_functions`` (the per-sample step
Function and the tail Function, built from scratch: the caches cleared) with the baseline's
module and with this checkout's, and whether both give the same bits at random arguments.

    .venv/bin/python benchmarks/lti_integrals_build.py [--baseline main] [--rounds 2]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from baseline import baseline_module

REPO = Path(__file__).resolve().parents[1]
MODULE = "feedtune/loops/sampled_lti_integrals.py"


def clear_caches(module) -> None:
    """Empty every lru cache of ``module``: its Functions are built again."""
    for value in vars(module).values():
        if hasattr(value, "cache_clear"):
            value.cache_clear()


def sampled_loops(cc) -> list:
    """(label, loop, samples): every ``implementation: sampled`` configuration of the contract
    cases ``cc`` at its nominal point, on its default box and on the factor-2 box around
    that point, whose horizon is within the sample limit."""
    loops = []
    for config in cc.CONFIGS:
        if "implementation=sampled" not in config.id:
            continue
        for label, box in (("default", config.default_box),
                           ("narrow", cc.narrow_box(config, cc.nominal(config)))):
            loop = config.plant.loop(cc.nominal(config), box)
            try:
                samples = loop.horizon_samples
            except ValueError:
                continue  # a horizon over the sample limit: nothing is summed
            loops.append((f"{config.id} {label}", loop, samples))
    return loops


def modules(description: str):
    """Parse ``--baseline``/``--rounds``, pin BLAS to one thread and load what both
    integral benchmarks compare: (arguments, the contract cases, this checkout's module,
    the baseline's module)."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--baseline", default="main", help="git revision of the old module")
    parser.add_argument("--rounds", type=int, default=2, help="alternating rounds")
    args = parser.parse_args()
    sys.path.insert(0, str(REPO / "tests" / "contract"))
    from feedtune.__main__ import pin_blas_threads

    pin_blas_threads()
    import contract_cases as cc
    import feedtune.loops.sampled_lti_integrals as new

    return args, cc, new, baseline_module(args.baseline, MODULE, "baseline_sampled_lti_integrals")


def main() -> None:
    args, cc, new, old = modules(__doc__.splitlines()[0])
    import numpy as np

    keys = [(label, new._key(loop, samples)) for label, loop, samples in sampled_loops(cc)]
    rng = np.random.default_rng(0)
    cpu = {"old": 0.0, "new": 0.0}
    identical = True
    for _ in range(args.rounds):
        for _, key in keys:
            for name in ("iae", "ise", "itae"):
                built = {}
                for label, module in (("old", old), ("new", new)):
                    clear_caches(module)
                    start = time.process_time()
                    built[label] = module._functions(key, name)
                    cpu[label] += time.process_time() - start
                for f_old, f_new in zip(built["old"], built["new"]):
                    point = [0.3 * rng.uniform(-1, 1, f_old.size_in(i))
                             for i in range(f_old.n_in())]
                    a, b = (np.array(f(*point), dtype=float) for f in (f_old, f_new))
                    identical &= bool(np.array_equal(a, b, equal_nan=True))
    print(f"{len(keys)} loop structures × 3 integrals × {args.rounds} rounds")
    print(f"CPU building the Functions: old {cpu['old']:.2f} s, new {cpu['new']:.2f} s, "
          f"new/old {cpu['new'] / cpu['old']:.2f}; identical values: {identical}")


if __name__ == "__main__":
    main()
