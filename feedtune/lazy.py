"""CasADi and numpy, imported when first used: a command that only checks a spec
(``feedtune validate``) builds no expression and computes no array, so it never pays for
their import (issue 15); nor, by :func:`load`, the plants and metrics that a spec does not
name and the commands that do not run.

Modules on that path write ``from feedtune.lazy import ca`` (or ``np``) and use the name
as the module.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Iterator, Mapping
from typing import Any


class _Lazy:
    """A module, imported by ``load()`` when an attribute is first read."""

    def __init__(self, load):
        self._load = load

    def __getattr__(self, name: str):
        module = self._load()
        self.__dict__.update(vars(module))  # later reads find the attribute directly
        return getattr(module, name)


def _casadi():
    import casadi

    return casadi


def _numpy():
    import numpy

    return numpy


ca = _Lazy(_casadi)
np = _Lazy(_numpy)


class Deferred:
    """An object built by ``build()`` when an attribute not given in ``known`` is first
    read; what ``known`` gives is answered without building.

    A loop of the user's sampled drive (:meth:`feedtune.plants.linear.Linear.sampled_loop`)
    holds its plant and controller this way: ``feedtune validate`` asks a loop which
    metrics it supports and never reads its matrices, so it imports neither numpy, scipy
    nor CasADi. Whatever the build can refuse must be checked before, in pure Python.
    """

    def __init__(self, build, **known):
        self._build = build
        self.__dict__.update(known)

    def __getattr__(self, name: str):  # only for names not found on the proxy itself
        if name.startswith("__"):
            raise AttributeError(name)
        built = self.__dict__.get("_built")
        if built is None:
            built = self._build()
            self.__dict__["_built"] = built
        return getattr(built, name)


def load(path: str):
    """The object at ``path``, ``"package.module:name"`` (the entry-point notation), its
    module imported now: a registry line of :mod:`feedtune.plants`,
    :mod:`feedtune.objectives` or the command line's commands, whose module a spec or a
    command line imports by naming its key (never a path a spec wrote)."""
    module, _, name = path.partition(":")
    return getattr(importlib.import_module(module), name)


class Loaded(Mapping):
    """A read-only mapping over the names of ``paths`` (name → ``"module:attribute"``), each
    value ``then(load(path))`` computed when read: ``in``, ``len`` and iterating import
    nothing.

    Examples: click's commands of ``feedtune`` by name (:mod:`feedtune.cli`), a plant type's
    Params model (:data:`feedtune.schema.spec.PLANT_MODELS`).
    """

    def __init__(self, paths: dict[str, str], then: Callable[[Any], Any] = lambda value: value):
        self._paths, self._then = paths, then

    def __getitem__(self, name: str):
        return self._then(load(self._paths[name]))

    def __contains__(self, name) -> bool:  # Mapping's would import the value
        return name in self._paths

    def __iter__(self) -> Iterator[str]:
        return iter(self._paths)

    def __len__(self) -> int:
        return len(self._paths)
