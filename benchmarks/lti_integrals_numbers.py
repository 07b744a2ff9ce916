"""The sampled LTI loop's step integrals on a loop of numbers (what a result reports for a
tuned design, and the metric contract's default box), new against a git revision's
``feedtune/loops/sampled_lti_integrals.py``, side by side in one process (issue 15).

For every ``implementation: sampled`` configuration of the contract tests
(``tests/contract/contract_cases.py``) with a continuous drive, the loop of numbers at its
nominal point on its default box and on the factor-2 box around that point, each of IAE,
ISE and ITAE: the CPU of ``step_integral`` from empty caches (its Functions built, then
evaluated over the loop's horizon) with the baseline's module and with this checkout's,
alternating, and the largest relative difference of the values.

    .venv/bin/python benchmarks/lti_integrals_numbers.py [--baseline main] [--rounds 2]
"""

from __future__ import annotations

import time

from lti_integrals_build import clear_caches, modules, sampled_loops


def main() -> None:
    args, cc, new, old = modules(__doc__.splitlines()[0])
    loops = [(label, loop, samples) for label, loop, samples in sampled_loops(cc)
             if loop.has_exact_step_error]
    cpu = {label: {"old": 0.0, "new": 0.0} for label, _, _ in loops}
    worst = 0.0
    for _ in range(args.rounds):
        for label, loop, samples in loops:
            for name in ("iae", "ise", "itae"):
                values = {}
                for side, module in (("old", old), ("new", new)):
                    clear_caches(module)
                    start = time.process_time()
                    values[side] = float(module.step_integral(loop, name, samples, True))
                    cpu[label][side] += time.process_time() - start
                worst = max(worst, abs(values["new"] - values["old"]) / abs(values["old"]))
    print(f"{len(loops)} loops of numbers × 3 integrals × {args.rounds} rounds "
          "(CPU s: baseline, new, new/baseline)")
    for label, times in cpu.items():
        print(f"  {label:<95} {times['old']:7.3f} {times['new']:7.3f} "
              f"{times['new'] / times['old']:6.3f}")
    total_old = sum(t["old"] for t in cpu.values())
    total_new = sum(t["new"] for t in cpu.values())
    print(f"all: baseline {total_old:.2f} s, new {total_new:.2f} s, new/baseline "
          f"{total_new / total_old:.3f}; largest relative difference of the values {worst:.1e}")


if __name__ == "__main__":
    main()
