"""Registry of metrics: spec ``metric`` name → metric class, one module each.

:data:`METRIC_PATHS` names each metric's class by module, and :func:`metric_class`
imports one: checking a spec imports the metrics it names, not the others (issue 15's
start-up). ``METRICS`` (name → class, a dict) imports every metric's module when first
read (``feedtune schema``, ``feedtune metrics``, the tuner, the contract tests).
"""

from feedtune.lazy import load

#: metric name → its class, as "module:Class"
METRIC_PATHS = {
    "iae": "feedtune.objectives.time.iae:Iae",
    "ise": "feedtune.objectives.time.ise:Ise",
    "itae": "feedtune.objectives.time.itae:Itae",
    "radial_error": "feedtune.objectives.contour.radial_error:RadialError",
    "radial_error_koren": "feedtune.objectives.contour.radial_error_koren:RadialErrorKoren",
    "damping_ratio": "feedtune.objectives.constants.damping_ratio:DampingRatio",
    "natural_frequency": "feedtune.objectives.constants.natural_frequency:NaturalFrequency",
    "min_radius": "feedtune.objectives.contour.min_radius:MinRadius",
    "min_radius_koren": "feedtune.objectives.contour.min_radius_koren:MinRadiusKoren",
    "encoder_ratio": "feedtune.objectives.constants.encoder_ratio:EncoderRatio",
    "sampling_ratio": "feedtune.objectives.constants.sampling_ratio:SamplingRatio",
    "counter_utilisation": "feedtune.objectives.constants.counter_utilisation:CounterUtilisation",
    "m_peak": "feedtune.objectives.frequency.m_peak:MPeak",
    "bandwidth": "feedtune.objectives.frequency.bandwidth:Bandwidth",
    "gain_margin": "feedtune.objectives.frequency.gain_margin:GainMargin",
    "phase_margin": "feedtune.objectives.frequency.phase_margin:PhaseMargin",
    "crossover_frequency": "feedtune.objectives.frequency.crossover_frequency:CrossoverFrequency",
    "velocity_constant": "feedtune.objectives.constants.velocity_constant:VelocityConstant",
    "sensitivity": "feedtune.objectives.constants.sensitivity:Sensitivity",
    "sensitivity_peak": "feedtune.objectives.frequency.sensitivity_peak:SensitivityPeak",
    "pole_damping": "feedtune.objectives.poles.pole_damping:PoleDamping",
    "decay_rate": "feedtune.objectives.poles.decay_rate:DecayRate",
    "settling_time": "feedtune.objectives.time.settling_time:SettlingTime",
    "overshoot": "feedtune.objectives.time.overshoot:Overshoot",
    "load_rejection": "feedtune.objectives.time.load_rejection:LoadRejection",
    "average_radius": "feedtune.objectives.contour.average_radius:AverageRadius",
    "radius_decrease": "feedtune.objectives.contour.radius_decrease:RadiusDecrease",
    "surface_roughness": "feedtune.objectives.contour.surface_roughness:SurfaceRoughness",
    "circle_mean_deviation": "feedtune.objectives.contour.circle_mean_deviation:CircleMeanDeviation",
    "circle_roughness": "feedtune.objectives.contour.circle_roughness:CircleRoughness",
    "circularity": "feedtune.objectives.contour.circularity:Circularity",
    "interpolation_ratio": "feedtune.objectives.constants.interpolation_ratio:InterpolationRatio",
    "reference_interval": "feedtune.objectives.constants.reference_interval:ReferenceInterval",
    "radius_decrease_gap": "feedtune.objectives.contour.radius_decrease_gap:RadiusDecreaseGap",
    "surface_roughness_gap": "feedtune.objectives.contour.surface_roughness_gap:SurfaceRoughnessGap",
    "motor_acceleration_margin": "feedtune.objectives.pulse.motor_acceleration_margin:MotorAccelerationMargin",
    "peak_commanded_acceleration": "feedtune.objectives.pulse.peak_commanded_acceleration:PeakCommandedAcceleration",
    "peak_measured_acceleration": "feedtune.objectives.pulse.peak_measured_acceleration:PeakMeasuredAcceleration",
    "pulse_final_error": "feedtune.objectives.pulse.pulse_final_error:PulseFinalError",
    "pulse_max_velocity": "feedtune.objectives.pulse.pulse_max_velocity:PulseMaxVelocity",
    "pulse_overshoot": "feedtune.objectives.pulse.pulse_overshoot:PulseOvershoot",
    "pulse_rise_time": "feedtune.objectives.pulse.pulse_rise_time:PulseRiseTime",
    "pulse_settling_time": "feedtune.objectives.pulse.pulse_settling_time:PulseSettlingTime",
    "sine_tracking_error": "feedtune.objectives.pulse.sine_tracking_error:SineTrackingError",
}


def metric_class(name: str) -> type:
    """The class of metric ``name`` (a key of :data:`METRIC_PATHS`), its module imported
    now."""
    return load(METRIC_PATHS[name])


def __getattr__(name: str):
    """``METRICS``: metric name → class, every metric's module imported on first read."""
    if name != "METRICS":
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    metrics = globals()["METRICS"] = {key: metric_class(key) for key in METRIC_PATHS}
    return metrics
