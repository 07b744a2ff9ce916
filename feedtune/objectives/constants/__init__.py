"""Closed-form constants of a loop or its sampling: damping ratio, natural
frequency, C_v, Bhatia's sensitivity, Koren's and Sato's ratios.
"""
