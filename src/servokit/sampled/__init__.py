"""Sampled-data analysis: what happens between the samples.

* Sensitivity and complementary sensitivity of sampled-data loops with multirate
  filters, ``|Ssd|``, ``|Tsd|``, ``Sd``, ``Td`` (book §4.2, eqs. 4.4-4.38):
  :func:`sampled_data_sensitivity`, :class:`Multirate`, :func:`sensitivity_plot`,
  :func:`sinusoid_response`.
* Unobservable oscillations (§4.3): :func:`unobservable_magnitude` and friends.
* Shock response spectrum of held inputs (§4.4): :func:`shock_response_spectrum`.
"""

from servokit.sampled.hdd_multirate import hdd_multirate, multirate_filter_4_68
from servokit.sampled.multirate import Multirate, zoh_response
from servokit.sampled.sensitivity import (
    SampledDataSensitivity,
    SinusoidResponse,
    discrete_plant,
    gamma_terms,
    sampled_data_sensitivity,
    sinusoid_response,
)
from servokit.sampled.sensitivity_plots import sensitivity_plot
from servokit.sampled.srs import (
    ShockResponseSpectrum,
    amplitude_spectrum,
    half_sine,
    held_samples,
    polynomial_wave,
    shock_response,
    shock_response_spectrum,
    spectrum_peaks,
    srs_plot,
)
from servokit.sampled.unobservable import (
    STEADY_STATE_SAMPLES,
    MeasurementTimeRequirement,
    SamplingInterval,
    UnobservableMagnitude,
    damped_sine_extrema,
    required_measurement_time,
    unacceptable_sampling_frequencies,
    unobservable_magnitude,
    unobservable_plot,
    unobservable_rms,
)

__all__ = [
    "hdd_multirate",
    "multirate_filter_4_68",
    # sensitivity (§4.2)
    "Multirate",
    "SampledDataSensitivity",
    "SinusoidResponse",
    "discrete_plant",
    "gamma_terms",
    "sampled_data_sensitivity",
    "sensitivity_plot",
    "sinusoid_response",
    "zoh_response",
    # unobservable oscillations (§4.3)
    "STEADY_STATE_SAMPLES",
    "MeasurementTimeRequirement",
    "SamplingInterval",
    "UnobservableMagnitude",
    "damped_sine_extrema",
    "required_measurement_time",
    "unacceptable_sampling_frequencies",
    "unobservable_magnitude",
    "unobservable_plot",
    "unobservable_rms",
    # shock response spectrum (§4.4)
    "ShockResponseSpectrum",
    "amplitude_spectrum",
    "half_sine",
    "held_samples",
    "polynomial_wave",
    "shock_response",
    "shock_response_spectrum",
    "spectrum_peaks",
    "srs_plot",
]
