"""Frequency-domain metrics of a linear loop: M_peak, bandwidth, margins,
crossover, the sensitivity peak M_s (base: frequency_domain).
"""
