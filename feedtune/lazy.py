"""CasADi, imported when first used: a command that only checks a spec (``feedtune
validate``) never builds an expression, so it never pays for the import (issue 15).

Modules that build expressions write ``from feedtune.lazy import ca`` and use ``ca`` as
the casadi module.
"""

from __future__ import annotations


class _Casadi:
    """The casadi module, imported when an attribute is first read."""

    def __getattr__(self, name: str):
        import casadi

        self.__dict__.update(vars(casadi))  # later reads find the attribute directly
        return getattr(casadi, name)


ca = _Casadi()
