"""Registry of metrics: spec ``metric`` name → metric class, one module each."""

from feedtune.objectives.average_radius import AverageRadius
from feedtune.objectives.bandwidth import Bandwidth
from feedtune.objectives.circle_mean_deviation import CircleMeanDeviation
from feedtune.objectives.circle_roughness import CircleRoughness
from feedtune.objectives.circularity import Circularity
from feedtune.objectives.counter_utilisation import CounterUtilisation
from feedtune.objectives.crossover_frequency import CrossoverFrequency
from feedtune.objectives.damping_ratio import DampingRatio
from feedtune.objectives.decay_rate import DecayRate
from feedtune.objectives.encoder_ratio import EncoderRatio
from feedtune.objectives.gain_margin import GainMargin
from feedtune.objectives.iae import Iae
from feedtune.objectives.interpolation_ratio import InterpolationRatio
from feedtune.objectives.ise import Ise
from feedtune.objectives.itae import Itae
from feedtune.objectives.load_rejection import LoadRejection
from feedtune.objectives.m_peak import MPeak
from feedtune.objectives.min_radius import MinRadius
from feedtune.objectives.min_radius_koren import MinRadiusKoren
from feedtune.objectives.natural_frequency import NaturalFrequency
from feedtune.objectives.overshoot import Overshoot
from feedtune.objectives.phase_margin import PhaseMargin
from feedtune.objectives.pole_damping import PoleDamping
from feedtune.objectives.radial_error import RadialError
from feedtune.objectives.radial_error_koren import RadialErrorKoren
from feedtune.objectives.radius_decrease import RadiusDecrease
from feedtune.objectives.radius_decrease_gap import RadiusDecreaseGap
from feedtune.objectives.reference_interval import ReferenceInterval
from feedtune.objectives.sampling_ratio import SamplingRatio
from feedtune.objectives.sensitivity import Sensitivity
from feedtune.objectives.sensitivity_peak import SensitivityPeak
from feedtune.objectives.settling_time import SettlingTime
from feedtune.objectives.surface_roughness import SurfaceRoughness
from feedtune.objectives.surface_roughness_gap import SurfaceRoughnessGap
from feedtune.objectives.velocity_constant import VelocityConstant
from feedtune.objectives.motor_acceleration_margin import MotorAccelerationMargin
from feedtune.objectives.peak_commanded_acceleration import PeakCommandedAcceleration
from feedtune.objectives.peak_measured_acceleration import PeakMeasuredAcceleration
from feedtune.objectives.pulse_final_error import PulseFinalError
from feedtune.objectives.pulse_max_velocity import PulseMaxVelocity
from feedtune.objectives.pulse_overshoot import PulseOvershoot
from feedtune.objectives.pulse_rise_time import PulseRiseTime
from feedtune.objectives.pulse_settling_time import PulseSettlingTime
from feedtune.objectives.sine_tracking_error import SineTrackingError

METRICS = {
    metric.name: metric
    for metric in (Iae, Ise, Itae, RadialError, RadialErrorKoren, DampingRatio,
                   NaturalFrequency, MinRadius, MinRadiusKoren, EncoderRatio, SamplingRatio,
                   CounterUtilisation, MPeak, Bandwidth, GainMargin, PhaseMargin,
                   CrossoverFrequency, VelocityConstant, Sensitivity, SensitivityPeak,
                   PoleDamping, DecayRate, SettlingTime, Overshoot,
                   LoadRejection, AverageRadius, RadiusDecrease, SurfaceRoughness,
                   CircleMeanDeviation, CircleRoughness, Circularity, InterpolationRatio,
                   ReferenceInterval, RadiusDecreaseGap, SurfaceRoughnessGap,
                   MotorAccelerationMargin, PeakCommandedAcceleration, PeakMeasuredAcceleration, PulseFinalError, PulseMaxVelocity, PulseOvershoot, PulseRiseTime, PulseSettlingTime, SineTrackingError)
}
