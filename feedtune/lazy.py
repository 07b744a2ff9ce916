"""CasADi and numpy, imported when first used: a command that only checks a spec
(``feedtune validate``) builds no expression and computes no array, so it never pays for
their import (issue 15).

Modules on that path write ``from feedtune.lazy import ca`` (or ``np``) and use the name
as the module.
"""

from __future__ import annotations


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
