"""Attitude from gyroscope + accelerometer + skylight polarization (Jin et al. 2021) and baselines.

Public API: :func:`estimate` (batch, an :class:`AttitudeEstimate`; default method ``iframe``), :func:`estimate_q`
(its (N, 4) quaternions only), :func:`simulate` (a simulated flight with truth), streaming filters :class:`AttitudeFilter` (iframe), :class:`QuasiNewton`,
:class:`GradientDescent`, :class:`ConjugateGradient`, :class:`MEKF` (each chunk a :class:`FilterRun`), the shared measurement model (:class:`PolarizationMeasurement`, :func:`measurement_error`,
:data:`DEFAULT_C_B_M`) and error metrics (:mod:`optinav.attitude.metrics`). The flight simulator and its constants live in the module
``optinav/attitude/simulate.py`` (import them with ``from optinav.attitude.simulate import PAPER_SITE``; the
package attribute ``optinav.attitude.simulate`` is the function).
"""

from optinav._lazy import lazy_package

# loaded on first use: `optinav attitude` reads and checks its file before the numba kernels load
_EXPORTS = {
    **dict.fromkeys(("DEFAULTS", "METHODS"), ".methods"),
    **dict.fromkeys(
        (
            "MEKF",
            "AttitudeEstimate",
            "AttitudeFilter",
            "ConjugateGradient",
            "FilterRun",
            "GradientDescent",
            "QuasiNewton",
            "estimate",
            "estimate_q",
            "initial_attitude",
            "make_filter",
        ),
        ".estimators",
    ),
    **dict.fromkeys(
        (
            "DEFAULT_C_B_M",
            "DEFAULT_C_B_M_ENU",
            "PolarizationMeasurement",
            "default_c_b_m",
            "measurement_error",
            "predicted_aop",
            "up_vector",
            "wrap_axial",
        ),
        ".measurement",
    ),
    "simulate": ".simulate",
}
lazy_package(__name__, _EXPORTS)

__all__ = [
    "DEFAULTS",
    "METHODS",
    "MEKF",
    "AttitudeEstimate",
    "AttitudeFilter",
    "ConjugateGradient",
    "FilterRun",
    "GradientDescent",
    "QuasiNewton",
    "estimate",
    "estimate_q",
    "initial_attitude",
    "make_filter",
    "simulate",
    "DEFAULT_C_B_M",
    "DEFAULT_C_B_M_ENU",
    "PolarizationMeasurement",
    "default_c_b_m",
    "measurement_error",
    "predicted_aop",
    "up_vector",
    "wrap_axial",
]
