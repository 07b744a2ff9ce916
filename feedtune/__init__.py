"""feedtune: tune CNC feed drives by optimisation.

Describe a drive and what matters (a :class:`Spec`, a dict or a JSON file), solve it,
get a :class:`Result` back::

    import feedtune
    result = feedtune.tune("examples/koren-1979-sampled-data.json")
    result.values              # tuned values by name [their units: result.units]
    result.metrics["iae"]      # every metric at the optimum, with its unit
    result.save("result.json") # the JSON `feedtune tune` writes
    result.to_control()        # python-control systems with named signals
    result.report("report")    # the HTML report and figures of `feedtune report`

Public names
------------
tune
    Solve a spec, as ``feedtune tune`` does; returns a :class:`Result`.
load_result
    Read a result JSON (of ``feedtune tune`` or ``feedtune batch``) into a :class:`Result`.
Result
    Tuned values, metrics, constraints, status; ``to_json``, ``save``, ``to_control``,
    ``report``, ``summary``.
Spec
    The spec as a pydantic model, to build in code (``Spec.model_validate(dict)``).
SpecError
    A spec that cannot be used; ``errors`` lists (JSON pointer, message).
ResultError
    A file that is not a feedtune result.
ControlSystems
    What ``Result.to_control`` returns.
ReportFiles
    What ``Result.report`` wrote.

They are imported on first use (module ``__getattr__``), so ``import feedtune`` loads
neither CasADi nor numpy, scipy, pydantic or python-control, and the command line starts
fast.
"""

__version__ = "0.1.0"

#: the public API, defined in :mod:`feedtune.api` and loaded when first read
_API = ("tune", "load_result", "Result", "Spec", "SpecError", "ResultError", "ControlSystems",
        "ReportFiles")

__all__ = ["__version__", *_API]


def __getattr__(name: str):
    """``feedtune.tune`` and the other public names: :mod:`feedtune.api`, imported now."""
    if name not in _API:
        raise AttributeError(f"module 'feedtune' has no attribute {name!r}")
    import feedtune.api

    value = getattr(feedtune.api, name)
    globals()[name] = value  # later reads find it directly
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_API})
