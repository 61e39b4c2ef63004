"""Accelerometer and gyroscope multi-position calibration without a turntable.

Modules: :mod:`~optinav.multipos.model` (norm-observation model, analytic Jacobian), :mod:`~.accel` (estimators:
LM/GN/TRF on pose means — the default —, the adaptive GA of Gao & Zhang 2019, Newton, PSO), :mod:`~.design`
(observability, the paper's Table 1, pose-scheme design), :mod:`~.static` (static-interval detection),
:mod:`~.gyro` (gyroscope from the turns between poses, imu_tk's method), :mod:`~.ferraris` (closed form),
:mod:`~.convert` (imu_tk and imucal parameterizations and files), :mod:`~.calibrate` (a raw log to a result),
:mod:`~.result` (RESULT.json), :mod:`~.simulate` (simulated sessions with truth).
"""

from optinav._lazy import lazy_package

# loaded on first use: `optinav calibrate accel` reads and checks its file before numba and scipy load
_EXPORTS = {
    "PoseStatistics": ".accel",
    "fit_accel": ".accel",
    "initial_estimate": ".accel",
    "pose_statistics": ".accel",
    "calibrate": ".calibrate",
    "design_scheme": ".design",
    "evaluate_scheme": ".design",
    "observability_vs_n": ".design",
    "predict_std": ".design",
    "ferraris_calibration": ".ferraris",
    "ferraris_from_sections": ".ferraris",
    "calibrate_gyro": ".gyro",
    "CalibrationResult": ".result",
    "simulate": ".simulate",
    "detect_static": ".static",
    "sections_from_list": ".static",
}
lazy_package(__name__, _EXPORTS)

__all__ = [
    "PoseStatistics",
    "fit_accel",
    "initial_estimate",
    "pose_statistics",
    "calibrate",
    "design_scheme",
    "evaluate_scheme",
    "observability_vs_n",
    "predict_std",
    "ferraris_calibration",
    "ferraris_from_sections",
    "calibrate_gyro",
    "CalibrationResult",
    "simulate",
    "detect_static",
    "sections_from_list",
]
