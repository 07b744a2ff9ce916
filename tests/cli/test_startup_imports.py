"""What the quick commands load (issue 15: `feedtune --help` and `feedtune validate` start in
under 0.3 s; benchmarks/startup.py measures the time). These tests hold the import set, not
the time: commands run through the real entry point (``feedtune.__main__.run``, what the
command runs before it exits) in a fresh interpreter, which lists after each command the
heavy packages it then holds in ``sys.modules`` (a package loaded by one command stays listed
after the later ones) and the garbage collections meanwhile. The tests of ``--help`` and
``validate`` read one such interpreter's commands (``probed``)."""

from __future__ import annotations

import ast
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
EXAMPLES = sorted((REPO / "examples").glob("*.json"))

#: run each ``feedtune ARGS`` of argv[1] in this interpreter; after each, print on stderr its
#: exit status, which packages of argv[2] (or their submodules) are loaded, how many cyclic
#: garbage collections started meanwhile and whether the collector is on
_PROBE = """
import gc, json, sys
commands, packages = json.loads(sys.argv[1]), json.loads(sys.argv[2])
collections = []
gc.callbacks.append(lambda phase, info: phase == "start" and collections.append(info["generation"]))
from feedtune.__main__ import run
for args in commands:
    collections.clear()
    status = run(args)
    heavy = [package for package in packages
             if any(name == package or name.startswith(package + ".") for name in sys.modules)]
    report = {"status": status, "heavy": heavy, "collections": len(collections),
              "enabled": gc.isenabled()}
    print("\\nloaded: " + json.dumps(report), file=sys.stderr)
"""

KOREN = REPO / "examples" / "koren-1979-sampled-data.json"
#: what the probe lists: the heavy packages of the tests below and every registered plant's
#: and metric's module
HEAVY = ("pydantic", "numpy", "casadi", "scipy", "matplotlib", "feedtune.tuner")


def loaded(commands: list[list[str]], packages: tuple[str, ...]) -> list[dict]:
    """The report (exit status, which of ``packages`` are loaded, the collections and the
    collector's state) after each of ``feedtune ARGS...``, run one after the other in one
    fresh interpreter."""
    proc = subprocess.run([sys.executable, "-c", _PROBE, json.dumps(commands),
                           json.dumps(packages)],
                          capture_output=True, text=True, cwd=REPO, timeout=120, check=True)
    reports = [json.loads(line.removeprefix("loaded: "))
               for line in proc.stderr.splitlines() if line.startswith("loaded: ")]
    assert len(reports) == len(commands), proc.stderr
    return reports


def _registered_modules() -> dict[str, str]:
    """Registry key → the module of its class, of every plant and metric."""
    from feedtune.objectives import METRIC_PATHS
    from feedtune.plants import PLANT_PATHS

    return {key: path.partition(":")[0] for key, path in {**PLANT_PATHS, **METRIC_PATHS}.items()}


def _with_registered_imports(modules: set[str], registered: set[str]) -> set[str]:
    """``modules`` and every registered module they import, directly or through another
    registered one (a metric subclassing another metric's class), read from their source."""
    found, todo = set(), list(modules)
    while todo:
        module = todo.pop()
        if module in found:
            continue
        found.add(module)
        source = (REPO / (module.replace(".", "/") + ".py")).read_text(encoding="utf-8")
        for node in ast.walk(ast.parse(source)):
            if isinstance(node, ast.ImportFrom) and node.module in registered:
                todo.append(node.module)
            elif isinstance(node, ast.Import):
                todo.extend(alias.name for alias in node.names if alias.name in registered)
    return found


@pytest.fixture(scope="module")
def probed() -> dict:
    """One fresh interpreter for the tests below (each was one of its own): ``--help``, then
    ``validate`` of Koren's sampled example, then of every bundled example one after the
    other. The lists are cumulative (a package loaded by one command stays listed after the
    later ones), so the examples' lists hold what the first two loaded as well."""
    commands = [["--help"], ["validate", str(KOREN)],
                *(["validate", str(path)] for path in EXAMPLES)]
    registered = sorted(set(_registered_modules().values()))
    help_, koren, *examples = loaded(commands, (*HEAVY, *registered))
    return {"help": help_, "koren": koren, "examples": dict(zip(EXAMPLES, examples))}


def _of(report: dict, packages: tuple[str, ...]) -> tuple[int, list[str]]:
    """(exit status, which of ``packages`` the report lists)."""
    return report["status"], [package for package in report["heavy"] if package in packages]


def test_help_loads_no_spec_model_or_numerical_package(probed):
    status, heavy = _of(probed["help"], ("pydantic", "numpy", "casadi", "scipy", "matplotlib"))
    assert status == 0
    assert heavy == []


def test_validate_loads_neither_scipy_nor_matplotlib_nor_the_tuner(probed):
    """Every bundled example, one after the other: the first to load one is named."""
    packages = ("scipy", "matplotlib", "feedtune.tuner")
    assert {path.stem: _of(report, packages) for path, report in probed["examples"].items()} == {
        path.stem: (0, []) for path in EXAMPLES}


def test_validate_loads_no_casadi(probed):
    """Koren's example, the first spec this interpreter validates."""
    status, heavy = _of(probed["koren"], ("casadi",))
    assert status == 0
    assert heavy == []


def test_validate_loads_neither_casadi_nor_numpy_on_any_example(probed):
    """Every bundled example, one after the other in one interpreter: the first to load one
    of them is named. Koren's reference-pulse examples ask a deferred loop
    (``Plant.checked_loop``), not one of CasADi matrices, which metrics it supports; the
    Ward-Leonard drive's frequency band takes D(s)'s modes in closed form, not from numpy."""
    packages = ("casadi", "numpy")
    assert {path.stem: _of(report, packages) for path, report in probed["examples"].items()} == {
        path.stem: (0, []) for path in EXAMPLES}


def test_validate_imports_only_the_plant_and_metrics_a_spec_names(probed):
    """Issue 15's start-up: the registries import a plant's or metric's module when a spec
    names it. Every bundled example, one after the other in one interpreter: after each,
    the plant and metric modules loaded are those of the plants and metrics named so far
    (and the registered modules these import), not the other registered ones."""
    modules = _registered_modules()
    registered = set(modules.values())
    named: set[str] = set()
    for path, report in [(KOREN, probed["koren"]), *probed["examples"].items()]:
        status, heavy = _of(report, tuple(registered))
        spec = json.loads(path.read_text())
        named |= {modules[spec["plant"]["type"]]}
        named |= {modules[term["metric"]]
                  for term in spec["objective"] + spec.get("constraints", [])}
        assert status == 0
        assert set(heavy) <= _with_registered_imports(named, registered), path.stem
    assert len(set(heavy)) < len(registered) / 2  # the examples name a few of them


#: ``feedtune validate ARGV[1]`` in this interpreter, counting the reads of every installed
#: distribution's entry points (how pydantic looks for plugins); the count on stderr
_ENTRY_POINT_READS = """
import importlib.metadata, json, sys
reads = []
read = importlib.metadata.entry_points
importlib.metadata.entry_points = lambda *args, **kwargs: reads.append(kwargs) or read(*args, **kwargs)
from feedtune.__main__ import run
status = run(["validate", sys.argv[1]])
print("\\nreads: " + json.dumps({"status": status, "reads": len(reads)}), file=sys.stderr)
"""


def test_validate_does_not_look_for_pydantic_plugins():
    """The command sets pydantic's PYDANTIC_DISABLE_PLUGINS (issue 15's start-up), so no
    entry point is read; a user's own setting is kept
    (``feedtune.__main__.skip_pydantic_plugins``)."""
    from feedtune.__main__ import skip_pydantic_plugins

    env = {name: value for name, value in os.environ.items() if name != "PYDANTIC_DISABLE_PLUGINS"}
    proc = subprocess.run([sys.executable, "-c", _ENTRY_POINT_READS,
                           str(REPO / "examples" / "koren-1979-sampled-data.json")],
                          capture_output=True, text=True, cwd=REPO, timeout=120, check=True, env=env)
    [line] = [line for line in proc.stderr.splitlines() if line.startswith("reads: ")]
    assert json.loads(line.removeprefix("reads: ")) == {"status": 0, "reads": 0}
    environ = {}
    skip_pydantic_plugins(environ)
    assert environ == {"PYDANTIC_DISABLE_PLUGINS": "__all__"}
    environ = {"PYDANTIC_DISABLE_PLUGINS": "logfire"}  # the user's: one plugin off
    skip_pydantic_plugins(environ)
    assert environ == {"PYDANTIC_DISABLE_PLUGINS": "logfire"}


def test_validate_starts_no_garbage_collection_and_gives_the_collector_back(probed):
    """Issue 15's start-up: loading click and pydantic and building a spec's models started
    ≈ 60 collections that found nothing to free (≈ 26 M of ≈ 690 M instructions), and the
    first one after a pause walked every object allocated meanwhile. The command line holds
    the collector off while it starts and ``validate`` while it checks
    (:mod:`feedtune.collector`); after each command it is on again. Koren's example (the
    first to load pydantic and build a spec's models), then every bundled example, one after
    the other in one interpreter."""
    reports = [("koren (first)", probed["koren"]),
               *((path.stem, report) for path, report in probed["examples"].items())]
    assert {name: (report["status"], report["collections"], report["enabled"])
            for name, report in reports} == {name: (0, 0, True) for name, _ in reports}


#: what ``feedtune tune`` and a batch's warm-up import to tune and validate a software servo:
#: the tuner, the validator, and the validator's model of that plant; the modules loaded
#: then, as JSON on stdout
_TUNER_AND_VALIDATOR = """
import json, sys
import feedtune.problem, feedtune.validate
from feedtune.batch.job import WARM_UP_SPEC
from feedtune.validate.models import model_for
model_for(WARM_UP_SPEC["plant"], {"position_gain": 20.0, "sampling_period": 0.015625})
print(json.dumps(sorted(sys.modules)))
"""


def test_a_tuning_loads_only_its_own_plants_validator():
    """Issue 15's start-up of ``tune`` and ``batch``: the validator imports a plant's model
    when a result of that plant is validated (``feedtune.validate.models.MODEL_PATHS``), and
    the measured-data validator (scipy.interpolate) only for measured data; before, every
    tuning process imported all of them."""
    proc = subprocess.run([sys.executable, "-c", _TUNER_AND_VALIDATOR], capture_output=True,
                          text=True, cwd=REPO, timeout=120, check=True)
    modules = set(json.loads(proc.stdout))
    others = {f"feedtune.validate.{name}" for name in (
        "hydraulic_rotary", "cascade", "ward_leonard", "pulse_generator", "linear",
        "sampled_linear", "frequency_data")}
    assert "feedtune.validate.software_servo" in modules
    assert modules & others == set()
    assert not any(name == "scipy.interpolate" or name.startswith("scipy.interpolate.")
                   for name in modules)
