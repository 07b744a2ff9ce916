"""Registry of metrics: spec ``metric`` name → metric class, one module each."""

from feedtune.objectives.constants.counter_utilisation import CounterUtilisation
from feedtune.objectives.constants.damping_ratio import DampingRatio
from feedtune.objectives.constants.encoder_ratio import EncoderRatio
from feedtune.objectives.constants.interpolation_ratio import InterpolationRatio
from feedtune.objectives.constants.natural_frequency import NaturalFrequency
from feedtune.objectives.constants.reference_interval import ReferenceInterval
from feedtune.objectives.constants.sampling_ratio import SamplingRatio
from feedtune.objectives.constants.sensitivity import Sensitivity
from feedtune.objectives.constants.velocity_constant import VelocityConstant
from feedtune.objectives.contour.average_radius import AverageRadius
from feedtune.objectives.contour.circle_mean_deviation import CircleMeanDeviation
from feedtune.objectives.contour.circle_roughness import CircleRoughness
from feedtune.objectives.contour.circularity import Circularity
from feedtune.objectives.contour.min_radius import MinRadius
from feedtune.objectives.contour.min_radius_koren import MinRadiusKoren
from feedtune.objectives.contour.radial_error import RadialError
from feedtune.objectives.contour.radial_error_koren import RadialErrorKoren
from feedtune.objectives.contour.radius_decrease import RadiusDecrease
from feedtune.objectives.contour.radius_decrease_gap import RadiusDecreaseGap
from feedtune.objectives.contour.surface_roughness import SurfaceRoughness
from feedtune.objectives.contour.surface_roughness_gap import SurfaceRoughnessGap
from feedtune.objectives.frequency.bandwidth import Bandwidth
from feedtune.objectives.frequency.crossover_frequency import CrossoverFrequency
from feedtune.objectives.frequency.gain_margin import GainMargin
from feedtune.objectives.frequency.m_peak import MPeak
from feedtune.objectives.frequency.phase_margin import PhaseMargin
from feedtune.objectives.frequency.sensitivity_peak import SensitivityPeak
from feedtune.objectives.poles.decay_rate import DecayRate
from feedtune.objectives.poles.pole_damping import PoleDamping
from feedtune.objectives.pulse.motor_acceleration_margin import MotorAccelerationMargin
from feedtune.objectives.pulse.peak_commanded_acceleration import PeakCommandedAcceleration
from feedtune.objectives.pulse.peak_measured_acceleration import PeakMeasuredAcceleration
from feedtune.objectives.pulse.pulse_final_error import PulseFinalError
from feedtune.objectives.pulse.pulse_max_velocity import PulseMaxVelocity
from feedtune.objectives.pulse.pulse_overshoot import PulseOvershoot
from feedtune.objectives.pulse.pulse_rise_time import PulseRiseTime
from feedtune.objectives.pulse.pulse_settling_time import PulseSettlingTime
from feedtune.objectives.pulse.sine_tracking_error import SineTrackingError
from feedtune.objectives.time.iae import Iae
from feedtune.objectives.time.ise import Ise
from feedtune.objectives.time.itae import Itae
from feedtune.objectives.time.load_rejection import LoadRejection
from feedtune.objectives.time.overshoot import Overshoot
from feedtune.objectives.time.settling_time import SettlingTime

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
