"""One spelling of a metric with its options, ``name(k=v,k=v)``: the key of a result's
``metrics``, and how the summary, the report, warnings and the tuner name a term.

Light on purpose (no numerical packages): the validator and the report use it too.
"""


def metric_label(name: str, options: dict | None = None) -> str:
    """``name`` alone without options, else ``name(k=v,k=v)`` in the options' order, e.g.
    ``iae(time=absolute,input=ramp)``."""
    if not options:
        return name
    return name + "(" + ",".join(f"{k}={v}" for k, v in options.items()) + ")"
