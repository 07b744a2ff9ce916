"""Metrics of the closed-loop poles, as MATLAB's TuningGoal.Poles: the smallest
damping ratio and the slowest decay rate (base: pole_region).
"""
