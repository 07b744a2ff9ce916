"""Closed-loop models and what evaluates them: the Loop and Plant protocols,
the Loop classes plants build (continuous, sampled-data, transfer function,
the general sampled LTI loop), their exact time responses, step-error
integrals, frequency peaks and crossings, the reference-pulse simulation,
and their export to python-control.
"""
