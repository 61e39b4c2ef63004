"""Attitude from gyroscope + accelerometer + skylight polarization (Jin et al. 2021) and baselines.

Public API: :func:`estimate` (batch, (N, 4) quaternions; default method ``iframe``), :func:`estimate_attitude`
(with diagnostics), streaming filters :class:`AttitudeFilter` (iframe), :class:`QuasiNewton`,
:class:`GradientDescent`, :class:`ConjugateGradient`, :class:`MEKF`, the shared measurement model (:class:`PolarizationMeasurement`, :func:`measurement_error`,
:data:`DEFAULT_C_B_M`) and error metrics (:mod:`optinav.attitude.metrics`). The flight simulator lives in
:mod:`optinav.attitude.simulate`.
"""

from optinav.attitude.estimators import (DEFAULTS, METHODS, MEKF, AttitudeEstimate, AttitudeFilter,
                                         ConjugateGradient, GradientDescent, QuasiNewton, estimate, estimate_attitude,
                                         initial_attitude, make_filter)
from optinav.attitude.measurement import (DEFAULT_C_B_M, DEFAULT_C_B_M_ENU, PolarizationMeasurement, default_c_b_m,
                                          measurement_error, predicted_aop, up_vector, wrap_axial)

__all__ = ["DEFAULTS", "METHODS", "MEKF", "AttitudeEstimate", "AttitudeFilter", "ConjugateGradient",
           "GradientDescent", "QuasiNewton", "estimate", "estimate_attitude", "initial_attitude", "make_filter", "DEFAULT_C_B_M", "DEFAULT_C_B_M_ENU",
           "PolarizationMeasurement", "default_c_b_m", "measurement_error", "predicted_aop", "up_vector",
           "wrap_axial"]
