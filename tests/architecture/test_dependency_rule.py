"""The dependency rule (docs/design.md): plant → Loop → metrics → tuner, nothing flows back.

* the tuner imports neither ``feedtune.plants`` nor ``feedtune.objectives``, nor the
  validator (``feedtune.validate``), which must judge its results with code of its own;
* an objective imports nothing from ``feedtune.plants``;
* a plant imports nothing from ``feedtune.objectives`` or ``feedtune.tuner``.

Checked twice: statically, by parsing every import (direct or through other feedtune
modules, package ``__init__`` files included), and at run time, by importing the package
in a fresh interpreter and looking at ``sys.modules``. Also the naming rule of STYLE.md:
``"ward_leonard"`` → ``plants/ward_leonard.py`` → ``WardLeonard``, ``WardLeonardParams``;
``"iae"`` → ``objectives/time/iae.py`` (one family folder) → ``Iae``.
"""

from __future__ import annotations

import ast
import inspect
import json
import os
import subprocess
import sys
import typing
from functools import lru_cache
from pathlib import Path

import pytest

import feedtune
from feedtune.objectives import METRICS
from feedtune.objectives.base import Metric
from feedtune.plants import DATA_PLANTS, PLANTS

PACKAGE_ROOT = Path(feedtune.__file__).resolve().parent
ALL_MODULES = sorted(PACKAGE_ROOT.rglob("*.py"))


def _module_name(path: Path, root: Path = PACKAGE_ROOT) -> str:
    parts = ["feedtune", *path.relative_to(root).with_suffix("").parts]
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


MODULE_PATHS = {_module_name(p): p for p in ALL_MODULES}


def _package_of(path: Path, root: Path) -> str:
    name = _module_name(path, root)
    return name if path.name == "__init__.py" else name.rpartition(".")[0]


@lru_cache(maxsize=None)
def direct_imports(path: Path, root: Path = PACKAGE_ROOT) -> frozenset[str]:
    """Dotted names a module imports: ``import a.b``, ``from a import b`` (→ a, a.b),
    relative imports resolved, and literal ``importlib.import_module``/``__import__`` calls."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    names: set[str] = set()
    for node in _import_time_nodes(tree, path, root):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = _package_of(path, root).split(".")
                base = base[: len(base) - (node.level - 1)]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            names.add(module)
            names.update(f"{module}.{alias.name}" for alias in node.names if alias.name != "*")
        elif isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant):
            func = node.func
            called = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
            if called in ("import_module", "__import__") and isinstance(node.args[0].value, str):
                names.add(node.args[0].value)
    return frozenset(names)


#: the root package's public facade may import these inside a function body, run on first
#: use only (its module ``__getattr__``: ``feedtune.tune``): every package imports the root
#: ``__init__``, so a module-level import there would pull the plants into the tuner
DEFERRED_FACADE = frozenset({"feedtune.api"})


def _import_time_nodes(tree: ast.AST, path: Path, root: Path):
    """Every node of ``tree``, except the bodies of functions in the root ``__init__.py``
    (checked by test_root_facade_defers_only_the_api instead)."""
    if path != root / "__init__.py":
        yield from ast.walk(tree)
        return
    todo = [tree]
    while todo:
        node = todo.pop()
        yield node
        if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            todo.extend(ast.iter_child_nodes(node))


def test_root_facade_defers_only_the_api():
    """What the root ``__init__`` imports inside functions is the API facade only."""
    root_init = PACKAGE_ROOT / "__init__.py"
    tree = ast.parse(root_init.read_text(encoding="utf-8"))
    deferred = set()
    for function in ast.walk(tree):
        if isinstance(function, (ast.FunctionDef, ast.AsyncFunctionDef)):
            for node in ast.walk(function):
                if isinstance(node, ast.Import):
                    deferred.update(alias.name for alias in node.names)
                elif isinstance(node, ast.ImportFrom):
                    deferred.add(node.module or "")
                    deferred.update(f"{node.module}.{a.name}" for a in node.names)
                elif isinstance(node, ast.Call):
                    called = getattr(node.func, "attr", getattr(node.func, "id", ""))
                    if called in ("import_module", "__import__"):
                        deferred.add("<dynamic import>")
    assert deferred <= DEFERRED_FACADE, sorted(deferred - DEFERRED_FACADE)


def _executed_modules(name: str) -> set[str]:
    """A dotted import executes the module and every parent package's __init__."""
    parts = name.split(".")
    return {".".join(parts[:i]) for i in range(1, len(parts) + 1)} & set(MODULE_PATHS)


def transitive_imports(module: str) -> set[str]:
    """Every feedtune module executed when ``module`` is imported (static estimate)."""
    seen: set[str] = set()
    todo = [module]
    while todo:
        current = todo.pop()
        for name in direct_imports(MODULE_PATHS[current]):
            for executed in _executed_modules(name):
                if executed not in seen:
                    seen.add(executed)
                    todo.append(executed)
    return seen - {module}


def _violations(names, forbidden: tuple[str, ...]) -> list[str]:
    return sorted(n for n in names if any(n == f or n.startswith(f + ".") for f in forbidden))


def _modules_under(package: str) -> list[str]:
    return sorted(n for n in MODULE_PATHS if n == package or n.startswith(package + "."))


RULES = [
    ("feedtune.tuner", ("feedtune.plants", "feedtune.objectives", "feedtune.validate")),
    ("feedtune.objectives", ("feedtune.plants", "feedtune.tuner")),
    ("feedtune.plants", ("feedtune.objectives", "feedtune.tuner")),
]
RULE_CASES = [(module, forbidden) for package, forbidden in RULES for module in _modules_under(package)]


def test_the_rule_covers_modules():
    covered = {m for m, _ in RULE_CASES}
    for package, _ in RULES:
        assert any(m.startswith(package + ".") for m in covered), f"no modules found under {package}"
    assert "feedtune.tuner.nlp" in covered


@pytest.mark.parametrize("module, forbidden", RULE_CASES, ids=[m for m, _ in RULE_CASES])
def test_module_imports_nothing_forbidden_directly(module, forbidden):
    assert not _violations(direct_imports(MODULE_PATHS[module]), forbidden)


@pytest.mark.parametrize("module, forbidden", RULE_CASES, ids=[m for m, _ in RULE_CASES])
def test_module_imports_nothing_forbidden_transitively(module, forbidden):
    assert not _violations(transitive_imports(module), forbidden)


def test_import_parser_sees_every_import_form(tmp_path):
    """The parser must not miss a violation written in any of the usual forms."""
    package = tmp_path / "feedtune" / "tuner"
    package.mkdir(parents=True)
    source = package / "probe.py"
    source.write_text(
        "import feedtune.plants.software_servo as ss\n"
        "from feedtune import objectives\n"
        "from ..plants import base\n"
        "from .. import objectives as obj\n"
        "import importlib\n"
        "importlib.import_module('feedtune.objectives.time.iae')\n")
    names = direct_imports(source, tmp_path / "feedtune")
    assert _violations(names, ("feedtune.plants",)) and _violations(names, ("feedtune.objectives",))
    assert {"feedtune.plants.software_servo", "feedtune.objectives", "feedtune.plants.base",
            "feedtune.objectives.time.iae"} <= names


#: third-party packages the ruled packages import (numpy, scipy and CasADi for the tuner,
#: pydantic for plants and metrics): loaded once by the interpreter that forks one child a
#: package in _IMPORTED_BY_PACKAGE
THIRD_PARTY = ("numpy", "scipy.linalg", "scipy.optimize", "casadi", "pydantic")

#: argv[1]: {package: its modules}. A fresh interpreter loads THIRD_PARTY and no feedtune
#: module, then forks a child a package, which imports every module of it and writes its
#: sorted sys.modules to a file of its own (argv[2]/<package>); the parent waits for each
_IMPORTED_BY_PACKAGE = """
import importlib, json, os, sys
for name in json.loads(sys.argv[3]):
    importlib.import_module(name)
assert not any(name == "feedtune" or name.startswith("feedtune.") for name in sys.modules)
for package, modules in json.loads(sys.argv[1]).items():
    pid = os.fork()
    if pid == 0:
        status = 1
        try:
            for name in modules:
                importlib.import_module(name)
            with open(os.path.join(sys.argv[2], package), "w") as out:
                out.write("\\n".join(sorted(sys.modules)))
            status = 0
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
            os._exit(status)
    _, status = os.waitpid(pid, 0)
    if os.waitstatus_to_exitcode(status) != 0:
        sys.exit(f"importing {package} failed")
"""


@pytest.fixture(scope="module")
def imported_by_package(tmp_path_factory) -> dict[str, list[str]]:
    """Package → the names in ``sys.modules`` after importing every module of it, in a child
    forked from a fresh interpreter that had loaded THIRD_PARTY and no feedtune module: as
    a fresh interpreter of its own would list them (every feedtune module there is one the
    package's imports loaded), without loading numpy, scipy, CasADi and pydantic three
    times (≈ 0.4 s of CPU; benchmarks/README.md "Branch h-tcli5")."""
    out = tmp_path_factory.mktemp("imported")
    packages = {package: _modules_under(package) for package, _ in RULES}
    # BLAS on one thread: numpy starts no thread pool, so the interpreter forks with none
    subprocess.run([sys.executable, "-c", _IMPORTED_BY_PACKAGE, json.dumps(packages), str(out),
                    json.dumps(THIRD_PARTY)], capture_output=True, text=True, check=True,
                   timeout=120, env={**os.environ, "OPENBLAS_NUM_THREADS": "1"})
    return {package: (out / package).read_text(encoding="utf-8").split() for package in packages}


@pytest.mark.parametrize("package, forbidden", RULES, ids=[p for p, _ in RULES])
def test_importing_the_package_loads_nothing_forbidden(package, forbidden, imported_by_package):
    """Run time: every module of the package imported where no feedtune module was loaded
    before (imported_by_package), then sys.modules listed."""
    out = imported_by_package[package]
    assert any(name.startswith(package + ".") for name in out)
    assert not _violations(out, forbidden)


VALIDATE_MODULES = _modules_under("feedtune.validate") + _modules_under("feedtune.report")
#: what the tuner computes with: the validator and the report must not lean on any of it
TUNER_SIDE = ("casadi", "feedtune.loops.loop", "feedtune.loops.linalg", "feedtune.plants",
              "feedtune.objectives", "feedtune.loops.pulse_train", "feedtune.loops.timeresponse",
              "feedtune.loops.frequency", "feedtune.loops.signals", "feedtune.problem",
              "feedtune.tuner")


@pytest.mark.parametrize("module", VALIDATE_MODULES)
def test_validator_and_report_are_independent_of_the_tuner(module):
    """docs/design.md: validate/ checks a design with numpy/scipy only, so that a loop is never
    called stable on CasADi's word alone; neither it, nor the report drawn from it, nor any
    feedtune module they use imports casadi or the tuner's own models and metrics."""
    for name in {module} | transitive_imports(module):
        imported = direct_imports(MODULE_PATHS[name])
        assert not _violations(imported, TUNER_SIDE), name


def test_every_plant_has_a_validator_model():
    """One model per plant type, ``validate/<key>.py``: a new plant is validated or this fails."""
    from feedtune.validate.models import MODEL_PATHS, model_class

    assert set(MODEL_PATHS) == set(PLANTS)
    for key in MODEL_PATHS:
        assert model_class(key).__module__ == f"feedtune.validate.{key}"


# -- registries and naming ---------------------------------------------------------------------

def _camel(key: str) -> str:
    return "".join(part.capitalize() for part in key.split("_"))


def test_registries_are_plain_dicts():
    assert type(PLANTS) is dict and type(METRICS) is dict
    assert PLANTS and METRICS


@pytest.mark.parametrize("key", sorted(PLANTS))
def test_plant_key_module_class_params_share_one_stem(key):
    cls = PLANTS[key]
    assert cls.__module__ == f"feedtune.plants.{key}"
    assert (PACKAGE_ROOT / "plants" / f"{key}.py").is_file()
    assert cls.__name__ == _camel(key)
    params = cls.Params
    assert params.__name__ == f"{_camel(key)}Params"
    assert params.__module__ == cls.__module__
    assert typing.get_args(params.model_fields["type"].annotation) == (key,)


@pytest.mark.parametrize("key", sorted(METRICS))
def test_metric_key_name_module_class_share_one_stem(key):
    cls = METRICS[key]
    assert cls.name == key
    package, _, stem = cls.__module__.rpartition(".")
    family = package.removeprefix("feedtune.objectives.")
    assert stem == key and package == f"feedtune.objectives.{family}" and "." not in family
    assert (PACKAGE_ROOT / "objectives" / family / f"{key}.py").is_file()
    assert cls.__name__ == _camel(key)


def test_every_metric_class_is_registered():
    """A metric module without its registry line would silently never run."""
    import importlib

    for module in _modules_under("feedtune.objectives"):
        mod = importlib.import_module(module)
        for _, obj in inspect.getmembers(mod, inspect.isclass):
            concrete = "name" in vars(obj)  # shared bases (StepErrorMetric) declare no name
            if issubclass(obj, Metric) and concrete and obj.__module__ == module:
                assert METRICS.get(obj.name) is obj, f"{module}.{obj.__name__} is not in METRICS"


def _defines_a_plant(module: str) -> bool:
    """A plant module defines a class with a ``Params`` model and a ``loop`` method; helper
    modules (base, compensator) define neither."""
    import importlib

    mod = importlib.import_module(module)
    return any(obj.__module__ == module and hasattr(obj, "Params") and callable(getattr(obj, "loop", None))
               for _, obj in inspect.getmembers(mod, inspect.isclass))


def test_every_plant_module_is_registered():
    """A plant module without its registry line would silently never run."""
    registered = {cls.__module__ for cls in PLANTS.values()}
    plant_modules = {m for m in _modules_under("feedtune.plants") if _defines_a_plant(m)}
    assert plant_modules == registered, (
        f"unregistered: {sorted(plant_modules - registered)}; "
        f"registered but not detected: {sorted(registered - plant_modules)}")


def test_plant_helper_modules_are_imported_by_a_plant():
    """A module under plants/ that defines no plant is a helper some plant uses (e.g. the
    compensators), not a plant left out of the registry."""
    helpers = [m for m in _modules_under("feedtune.plants")
               if m != "feedtune.plants" and not _defines_a_plant(m)]
    used = set()
    for cls in PLANTS.values():
        used |= transitive_imports(cls.__module__)
    for module in DATA_PLANTS.values():  # plants of measured data (the convex technique)
        used |= {module} | transitive_imports(module)
    for module in helpers:
        assert module in used, f"{module} defines no plant and no registered plant uses it"
