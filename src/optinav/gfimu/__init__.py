"""Gyro-free IMU: accelerometer-array model, identifiability, rate solvers, installation errors and their
turntable calibration (Hao & Liu, Electric Machines and Control 15(1), 2011). See docs/methods/gfimu.md."""

from optinav.gfimu.array import AccelerometerArray, Identifiability, builtin, identifiability, quadratic_products
from optinav.gfimu.errors import InstallationErrors, coning_motion, error_effect, perturb, spinning_motion
from optinav.gfimu.solve import (
    RATE_METHODS,
    rate_gauss_newton,
    rate_integration,
    rate_quadratic,
    solve_linear,
    solve_rate,
)
from optinav.gfimu.turntable import (
    TurntableCalibration,
    TurntableData,
    calibrate,
    closed_form,
    scheme_identifiability,
    simulate,
)

__all__ = [
    "AccelerometerArray",
    "Identifiability",
    "builtin",
    "identifiability",
    "quadratic_products",
    "InstallationErrors",
    "coning_motion",
    "spinning_motion",
    "error_effect",
    "perturb",
    "RATE_METHODS",
    "solve_linear",
    "solve_rate",
    "rate_integration",
    "rate_quadratic",
    "rate_gauss_newton",
    "TurntableCalibration",
    "TurntableData",
    "calibrate",
    "closed_form",
    "scheme_identifiability",
    "simulate",
]
