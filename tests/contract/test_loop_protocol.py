"""Contract of the Loop and Plant protocols (feedtune/loops/protocols.py).

* every loop a plant of the registry builds, in every configuration, is of a class that
  declares its capabilities, and offers only capabilities its class declares;
* a loop class has every member of :class:`~feedtune.loops.protocols.Loop` and of the protocol
  of each capability it declares, and declares every capability whose members it has
  (a method added without its declaration is not silently unused, nor a declaration
  without its methods silently broken);
* every ``Capability.X`` written in ``feedtune/`` is a capability that exists (a misspelt
  one would otherwise surface only when that code runs), and no module probes a loop or
  a plant with ``getattr``/``hasattr``;
* every plant of the registry has the members of :class:`~feedtune.loops.protocols.Plant`.
"""

from __future__ import annotations

import ast
import dataclasses
import inspect
import typing

import pytest

from contract_cases import ALL_CONFIGS, CONFIGS, PACKAGE_ROOT, nominal, package_trees
from feedtune.loops.protocols import PROTOCOLS, Capability, DeclaredCapabilities, Loop, Plant
from feedtune.plants import PLANTS


def protocol_members(protocol: type) -> set[str]:
    """Names a protocol requires: its annotations and methods, its bases' included."""
    names: set[str] = set()
    for cls in protocol.__mro__:
        if cls in (typing.Protocol, typing.Generic, object):
            continue
        names.update(cls.__dict__.get("__annotations__", {}))
        names.update(name for name, value in cls.__dict__.items()
                     if callable(value) and not name.startswith("_"))
    return names


def class_members(cls: type) -> set[str]:
    """Names a class has without building an instance: attributes, properties, methods,
    and dataclass fields (those without a default are not class attributes)."""
    names = set(dir(cls))
    if dataclasses.is_dataclass(cls):
        names.update(f.name for f in dataclasses.fields(cls))
    return names


def _registry_loops():
    """(configuration id, loop at its nominal point) for every plant configuration."""
    loops = []
    for config in ALL_CONFIGS:
        point = (nominal(config) if config in CONFIGS
                 else {n: t.max for n, t in config.tunables.items()})
        loops.append((config.id, config.plant.loop(point, config.default_box)))
    return loops


REGISTRY_LOOPS = _registry_loops()


def _loop_classes() -> list[type]:
    """Every concrete class that declares capabilities, after the registry built its loops."""
    found, stack = set(), [DeclaredCapabilities]
    while stack:
        for sub in stack.pop().__subclasses__():
            stack.append(sub)
            if not sub.__name__.startswith("_"):
                found.add(sub)
    return sorted(found, key=lambda c: c.__qualname__)


LOOP_CLASSES = _loop_classes()


@pytest.mark.parametrize("config_id, loop", REGISTRY_LOOPS, ids=[i for i, _ in REGISTRY_LOOPS])
def test_registry_loop_declares_capabilities(config_id, loop):
    assert isinstance(loop, DeclaredCapabilities), \
        f"{config_id}: {type(loop).__name__} declares nothing"
    assert type(loop) in LOOP_CLASSES
    offered = {c for c in Capability if loop.offers(c)}
    assert all(isinstance(loop.offers(c), bool) for c in Capability)
    assert offered <= type(loop).capabilities, config_id
    assert loop.exact_only == (Capability.LINEAR not in type(loop).capabilities), \
        f"{config_id}: exact_only is the absence of a linear model"


def test_every_loop_class_is_built_by_some_plant():
    built = {type(loop) for _, loop in REGISTRY_LOOPS}
    assert set(LOOP_CLASSES) == built


@pytest.mark.parametrize("cls", LOOP_CLASSES, ids=lambda c: c.__name__)
def test_loop_class_has_what_it_declares(cls):
    members = class_members(cls)
    missing = protocol_members(Loop) - members
    assert not missing, f"{cls.__name__} lacks members of Loop: {sorted(missing)}"
    assert isinstance(cls.capabilities, frozenset)
    for capability in cls.capabilities:
        missing = protocol_members(PROTOCOLS[capability]) - members
        assert not missing, (f"{cls.__name__} declares {capability.name} but lacks "
                             f"{sorted(missing)} of {PROTOCOLS[capability].__name__}")


@pytest.mark.parametrize("cls", LOOP_CLASSES, ids=lambda c: c.__name__)
def test_loop_class_declares_what_it_has(cls):
    members = class_members(cls)
    undeclared = [c.name for c in Capability if c not in cls.capabilities
                  and protocol_members(PROTOCOLS[c]) <= members]
    assert not undeclared, (f"{cls.__name__} has every member of {undeclared} but does not "
                            "declare it in `capabilities`: metrics will not read them")


def test_every_capability_has_a_protocol():
    assert set(PROTOCOLS) == set(Capability)
    for capability, protocol in PROTOCOLS.items():
        assert protocol_members(protocol), capability
        assert inspect.getdoc(protocol), capability


def test_capabilities_named_in_the_code_exist():
    """A misspelt ``Capability.FREQUENCY_RESPONSES`` fails here, not when a metric runs."""
    unknown = []
    for path, tree in package_trees("Capability"):  # the modules that name it
        for node in ast.walk(tree):
            if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
                    and node.value.id == "Capability" and node.attr not in Capability.__members__
                    and not node.attr.startswith("_")):
                unknown.append(f"{path.relative_to(PACKAGE_ROOT)}:{node.lineno} {node.attr}")
    assert not unknown, f"capabilities that do not exist: {unknown}"


def _probe_target(call: ast.Call) -> str | None:
    """``loop`` or ``plant`` when ``call`` probes one (or its type) for a member named by a
    constant: ``hasattr(loop, "x")``, or ``getattr(loop, "x", default)``."""
    if not (isinstance(call.func, ast.Name) and len(call.args) >= 2
            and isinstance(call.args[1], ast.Constant)
            and (call.func.id == "hasattr"
                 or (call.func.id == "getattr" and len(call.args) == 3))):
        return None
    target = call.args[0]
    if (isinstance(target, ast.Call) and isinstance(target.func, ast.Name)
            and target.func.id == "type" and target.args):
        target = target.args[0]
    if isinstance(target, ast.Name) and target.id in ("loop", "plant"):
        return target.id
    return None


def test_no_capability_probes():
    """Loops and plants are read through their declared members, never probed by name."""
    probes = []
    for path, tree in package_trees("hasattr", "getattr"):  # the modules that call one
        for node in ast.walk(tree):
            if isinstance(node, ast.Call) and (target := _probe_target(node)):
                probes.append(f"{path.relative_to(PACKAGE_ROOT)}:{node.lineno} "
                              f"{node.func.id}({target}, ...)")
    assert not probes, f"capability probes on loops or plants: {probes}"


@pytest.mark.parametrize("config", ALL_CONFIGS, ids=[c.id for c in ALL_CONFIGS])
def test_plant_has_the_protocols_members(config):
    plant = config.plant
    missing = [name for name in protocol_members(Plant) if not hasattr(plant, name)]
    assert not missing, f"{config.id} lacks {missing} of Plant"
    assert plant.position_unit in ("m", "rad")
    assert "type" in plant.Params.model_fields
    parameters = inspect.signature(plant.loop).parameters
    assert list(parameters)[:3] == ["values", "box", "horizon_scale"], config.id


def test_every_plant_is_enrolled():
    assert {c.key for c in ALL_CONFIGS} == set(PLANTS)
