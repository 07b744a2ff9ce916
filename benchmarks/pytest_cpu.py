"""Where the test suite's CPU goes: a pytest plugin and its summary (issue 15).

Records, for every test (its setup, call and teardown together), the CPU time of the test
process (``RUSAGE_SELF``, user + sys) and of the processes it waited for
(``RUSAGE_CHILDREN``: ``python -m feedtune`` and the batch workers, Dask's scheduler and
workers when their parent waited for them), and, per test process, the CPU spent before
the first test (start-up and collection). Each process (the xdist controller and every
worker) appends its rows as JSON lines to ``$PYTEST_CPU_OUT`` (default
``pytest-cpu.jsonl``).

Run it beside the README's command, from the repository root::

    PYTEST_CPU_OUT=/tmp/cpu.jsonl .venv/bin/python -m pytest -p benchmarks.pytest_cpu
    .venv/bin/python benchmarks/pytest_cpu.py /tmp/cpu.jsonl            # per file
    .venv/bin/python benchmarks/pytest_cpu.py /tmp/cpu.jsonl --tests 20 # slowest tests

Times are CPU seconds (not wall): on a machine shared with other work they still grow
with the load (caches, frequency), so compare runs made at similar load, or side by side.
"""

import argparse
import collections
import json
import os
import resource
import sys
import time


def _cpu(who) -> float:
    usage = resource.getrusage(who)
    return usage.ru_utime + usage.ru_stime


class _Recorder:
    def __init__(self, path: str, worker: str):
        self.path = path
        self.worker = worker
        self.start = None

    def _write(self, row: dict):
        row["worker"] = self.worker
        row["wall"] = time.time()  # when the row was written [s since the epoch]
        with open(self.path, "a") as out:
            out.write(json.dumps(row) + "\n")

    def pytest_collection_finish(self, session):
        self._write({"kind": "collected", "self": _cpu(resource.RUSAGE_SELF),
                     "children": _cpu(resource.RUSAGE_CHILDREN),
                     "tests": len(session.items)})

    def pytest_runtest_protocol(self, item, nextitem):
        self.start = (_cpu(resource.RUSAGE_SELF), _cpu(resource.RUSAGE_CHILDREN))

    def pytest_runtest_logfinish(self, nodeid, location):
        if self.start is None:
            return
        self_cpu, children = self.start
        self._write({"kind": "test", "id": nodeid,
                     "self": _cpu(resource.RUSAGE_SELF) - self_cpu,
                     "children": _cpu(resource.RUSAGE_CHILDREN) - children})
        self.start = None

    def pytest_unconfigure(self, config):
        self._write({"kind": "end", "self": _cpu(resource.RUSAGE_SELF),
                     "children": _cpu(resource.RUSAGE_CHILDREN)})


def pytest_configure(config):
    worker = getattr(config, "workerinput", {}).get("workerid", "main")
    config.pluginmanager.register(
        _Recorder(os.environ.get("PYTEST_CPU_OUT", "pytest-cpu.jsonl"), worker),
        "pytest_cpu_recorder")


def replay(files: list[tuple[str, int, float]], workers: int = 2) -> list[float]:
    """Each worker's busy time [s] under ``--dist loadfile`` as pytest-xdist schedules it:
    files (name, tests, CPU s) queued by their number of tests, largest first
    (``--loadscope-reorder``), each worker holding two files and taking the next one as it
    finishes one; a file takes its CPU time (a worker alone on its core)."""
    queue = sorted(files, key=lambda f: -f[1])
    busy = [0.0] * workers
    held = [[] for _ in range(workers)]  # end times of the files a worker holds
    for worker in range(workers):  # the first file each, then a second
        held[worker].append(queue.pop(0)[2] if queue else 0.0)
    for worker in range(workers):
        if queue:
            held[worker].append(held[worker][-1] + queue.pop(0)[2])
    while queue:  # the worker whose first held file ends first takes the next
        worker = min(range(workers), key=lambda w: held[w][0])
        done = held[worker].pop(0)
        start = held[worker][-1] if held[worker] else done
        held[worker].append(start + queue.pop(0)[2])
    for worker in range(workers):
        busy[worker] = max(held[worker]) if held[worker] else 0.0
    return busy


def summarise(path: str, tests: int) -> None:
    """Print the CPU per file (worker and children) and the slowest tests."""
    per_file = collections.defaultdict(lambda: [0, 0.0, 0.0])
    per_test = []
    per_worker = collections.defaultdict(lambda: [0.0, 0.0, 0.0])
    last_test = {}  # worker → wall-clock time of its last test's end [s since the epoch]
    first_wall = None
    with open(path) as rows:
        for line in rows:
            row = json.loads(line)
            if "wall" in row:
                first_wall = row["wall"] if first_wall is None else min(first_wall, row["wall"])
            if row["kind"] == "test":
                entry = per_file[row["id"].split("::")[0]]
                entry[0] += 1
                entry[1] += row["self"]
                entry[2] += row["children"]
                per_test.append((row["self"] + row["children"], row["id"]))
                per_worker[row["worker"]][0] += row["self"] + row["children"]
                if "wall" in row:
                    last_test[row["worker"]] = row["wall"]
            elif row["kind"] == "collected":
                per_worker[row["worker"]][1] = row["self"] + row["children"]
            elif row["kind"] == "end":
                per_worker[row["worker"]][2] = row["self"] + row["children"]
    print(f"{'file':70s} {'tests':>6s} {'self s':>8s} {'children s':>10s} {'sum s':>8s}")
    for name, (count, own, children) in sorted(per_file.items(),
                                               key=lambda kv: -(kv[1][1] + kv[1][2])):
        print(f"{name:70s} {count:6d} {own:8.1f} {children:10.1f} {own + children:8.1f}")
    total_self = sum(v[1] for v in per_file.values())
    total_children = sum(v[2] for v in per_file.values())
    print(f"{'all':70s} {sum(v[0] for v in per_file.values()):6d} {total_self:8.1f} "
          f"{total_children:10.1f} {total_self + total_children:8.1f}")
    for worker, (in_tests, collected, end) in sorted(per_worker.items()):
        print(f"process {worker}: start-up and collection {collected:.1f} s, "
              f"in tests {in_tests:.1f} s, whole process {end:.1f} s (CPU)")
    for worker, wall in sorted(last_test.items()):
        print(f"process {worker}: last test ended {wall - first_wall:.1f} s (wall) after "
              f"the first row was written")
    busy = replay([(name, v[0], v[1] + v[2]) for name, v in per_file.items()])
    print("loadfile replayed on these CPU times, each worker busy: "
          + ", ".join(f"{b:.1f} s" for b in busy))
    if tests:
        print()
        for cpu, nodeid in sorted(per_test, reverse=True)[:tests]:
            print(f"{cpu:8.2f}  {nodeid}")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("path")
    parser.add_argument("--tests", type=int, default=0, help="also list the N slowest tests")
    args = parser.parse_args()
    summarise(args.path, args.tests)
    sys.exit(0)
