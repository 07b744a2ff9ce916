"""Contouring metrics of a circle tracked by two axes: radial error, minimum
radius, Sato's average radius, decrease in radius and roughness, and the
exact circle test (bases: circle, circle_test, formula_gap).
"""
