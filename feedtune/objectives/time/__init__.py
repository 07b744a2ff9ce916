"""Time-domain metrics of a position step, ramp or load step: IAE, ISE, ITAE,
overshoot, settling time, load rejection (base: step_error).
"""
