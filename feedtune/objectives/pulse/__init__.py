"""Metrics of a reference-pulse generator's exact pulse train (Tian et al.)
(base: pulse_metric).
"""
