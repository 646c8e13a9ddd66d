"""Performance limits of feedback loops (book §6.1.1 and §6.3): Bode sensitivity
integrals (6.17)-(6.22), the waterbed bound (6.20), the output-variance bound
(6.13)-(6.16) and the dynamic range of §6.1.1."""

from servokit.limits.accuracy import (
    VarianceBound,
    VarianceComparison,
    dynamic_range,
    output_variance,
    rolloff_bandwidth,
    variance_against_bound,
    variance_lower_bound,
)
from servokit.limits.bode import (
    BodeIntegral,
    continuous_bode_integral,
    discrete_bode_integral,
    high_frequency_gain,
    waterbed_lower_bound,
    waterbed_phi1,
)
from servokit.limits.rational import RationalLoop

__all__ = [
    "BodeIntegral",
    "RationalLoop",
    "VarianceBound",
    "VarianceComparison",
    "continuous_bode_integral",
    "discrete_bode_integral",
    "dynamic_range",
    "high_frequency_gain",
    "output_variance",
    "rolloff_bandwidth",
    "variance_against_bound",
    "variance_lower_bound",
    "waterbed_lower_bound",
    "waterbed_phi1",
]
