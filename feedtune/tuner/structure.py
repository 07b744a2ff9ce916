"""The part of a problem that its structure alone decides: the symbolic loop and metric
values, their scans and the evaluator, built once per structure and process.

Every number of a problem that shapes no graph enters it as an NLP parameter (fixed
tunables, the plant's numbers, lifted metric options, objective weights): the values of
the loop, the terms and the bounds are then the same expressions for every spec of one
structure. A caller that knows the structure from the spec before building anything
(``feedtune.problem.structure_key``) hands its key to :class:`~feedtune.tuner.nlp.Problem`,
which takes these pieces from :func:`feedtune.tuner.cache.cached_structure` instead of
building the graph again; only the per-spec numbers (parameter values, scales at the
starts, bounds) are computed for each spec.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Mapping

import casadi as ca

from feedtune.tuner.builder import NlpBuilder
from feedtune.tuner.cache import structure_key
from feedtune.tuner.evaluation import Evaluator
from feedtune.tuner.supremum import make_scan
from feedtune.tuner.types import Bound, Term, Variable


@dataclass
class Structure:
    """The symbolic NLP pieces of one problem structure.

    ``z`` the log tunables; ``leading`` the parameters the loop and the weights read, by
    name (``fixed_<tunable>``, ``number_<name>``, ``weight<i>``) in the order they were
    made; the rest are the metric values on the symbolic loop, their scans and the
    Functions and solver key once the first problem of this structure built them.
    """

    z: ca.MX
    leading: list[tuple[str, ca.MX]]
    discrete: bool
    unrolled_steps: int
    term_values: list
    bound_values: list
    stability: list
    settling: list
    matrices: dict
    term_scans: list
    bound_scans: list
    evaluator: Evaluator
    #: names of the loop's embedded numbers its graph read (feedtune.tuner.cache.
    #: StructureKey), None when the loop records none
    embedded_reads: frozenset | None = None
    #: (Functions, key-only Functions, expand) of the first problem built on it
    build: tuple | None = None
    _keys: dict[str, str] = field(default_factory=dict)

    @property
    def weights(self) -> list[ca.MX]:
        """The objective weights' parameters, in term order."""
        return [symbol for name, symbol in self.leading if name.startswith("weight")]

    def builder(self, variables: list[Variable], values: Mapping[str, float]) -> NlpBuilder:
        """A builder on this structure's symbols whose leading parameters hold ``values``
        (by parameter name) for one problem; symbolic until the structure's Functions are
        built (:attr:`build`), after which a problem needs only its numbers."""
        builder = NlpBuilder(variables, self.z, symbolic=self.build is None)
        for name, symbol in self.leading:
            builder.parameter(name, values[name], symbol)
        return builder

    def solver_key(self, options: Mapping) -> str:
        """:func:`feedtune.tuner.cache.structure_key` of the built Functions with these
        nlpsol options (each serialized once per structure)."""
        functions, key_extra, expand = self.build
        text = repr(sorted(options.items(), key=lambda item: item[0]))
        if text not in self._keys:
            self._keys[text] = structure_key({**functions, **key_extra}, options, expand)
        return self._keys[text]


def leading_values(fixed: Mapping[str, float], numbers: Mapping[str, float],
                   objective: list[Term]) -> dict[str, float]:
    """The leading parameters' values of one problem, by parameter name."""
    return {**{f"fixed_{name}": value for name, value in fixed.items()},
            **{f"number_{name}": value for name, value in numbers.items()},
            **{f"weight{i}": term.weight for i, term in enumerate(objective)}}


def build_structure(variables: list[Variable], fixed: Mapping[str, float],
                    numbers: Mapping[str, float], make_loop: Callable, objective: list[Term],
                    constraints: list[Bound]) -> Structure:
    """The symbolic loop of free tunables exp(z) with the fixed tunables and ``numbers`` as
    parameters (``make_loop(values)``, values by name), and every value the NLP needs on it."""
    builder = NlpBuilder(variables)
    values = {v.name: ca.exp(builder.z[i]) for i, v in enumerate(variables)}
    values.update({name: builder.parameter(f"fixed_{name}", value)
                   for name, value in fixed.items()})
    values.update({name: builder.parameter(f"number_{name}", value)
                   for name, value in numbers.items()})
    loop = make_loop(values)
    weights = [builder.parameter(f"weight{i}", t.weight) for i, t in enumerate(objective)]
    term_values = [t.value(loop) for t in objective]
    bound_values = [b.value(loop) for b in constraints]
    stability = loop.stability_conditions()
    settling = loop.settling_conditions()  # after the terms: they say what was summed
    matrices = loop.stability_matrices()
    z, p = builder.z, builder.p  # the parameters so far: the loop's, and the weights
    term_scans = [make_scan(f"term{i}", v, z, p) for i, v in enumerate(term_values)]
    bound_scans = [make_scan(f"bound{i}", v, z, p) for i, v in enumerate(bound_values)]
    evaluator = Evaluator(z, p, term_values, [t.weight for t in objective], term_scans,
                          bound_values, bound_scans, stability, settling, matrices,
                          [t.group for t in objective])
    names = [*(f"fixed_{name}" for name in fixed), *(f"number_{name}" for name in numbers),
             *(f"weight{i}" for i in range(len(weights)))]
    return Structure(z=z, leading=list(zip(names, builder.parameters)), discrete=loop.discrete,
                     unrolled_steps=loop.unrolled_steps, term_values=term_values,
                     bound_values=bound_values, stability=stability, settling=settling,
                     matrices=matrices, term_scans=term_scans, bound_scans=bound_scans,
                     evaluator=evaluator, embedded_reads=loop.embedded_reads())

