"""feedtune: tune CNC feed drives by optimisation."""

__version__ = "0.1.0"
