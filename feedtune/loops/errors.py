"""The error a sampled loop's model raises, which checking a spec catches.

Its own module so that ``feedtune validate`` of a plant without a sampled state-space model
does not import :mod:`feedtune.loops.sampled_plants` (its dataclasses' generated methods,
≈ 7 M instructions; issue 15's start-up, benchmarks/README.md); that module re-exports it.
"""


class SampledModelError(ValueError):
    """A plant, controller or dead time the sampled loop cannot take; names the field."""
