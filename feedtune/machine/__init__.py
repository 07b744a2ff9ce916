"""Multi-axis machines: paths from part programs, interpolation, simulation and contour
metrics (issue 18)."""
