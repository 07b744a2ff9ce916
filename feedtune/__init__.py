"""feedtune: tune CNC feed drives by optimisation."""

__version__ = "0.1.0"

__all__ = ["__version__", "load_result"]


def load_result(path):
    """Read a result JSON of ``feedtune tune``; see :func:`feedtune.export.load_result`.

    ``feedtune.load_result(path).to_control()`` gives the tuned loop as python-control
    systems (closed loop position reference → position, open loop, error; discrete with
    ``dt`` = the sampling period for a sampled loop).

    Imported on first call, so that ``import feedtune`` (and every module under it) does
    not load the plants or python-control.
    """
    from feedtune.export import load_result as load

    return load(path)
