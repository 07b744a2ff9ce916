"""The documents feedtune reads and writes: the JSON spec's models (built from
the registries), the result's models and status vocabulary, their strict
base model, the spelling of a metric's key, and atomic writing of files.
"""
