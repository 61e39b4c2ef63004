"""Dual-axis rotational INS: gimbal non-orthogonality calibration (Li et al., Infrared and Laser Eng. 2023).

Modules: :mod:`~optinav.rins.model` (gimbal chain, eqs. 1–6, residual eqs. 12–14 and its Jacobian),
:mod:`~optinav.rins.simulate` (static-base sessions), :mod:`~optinav.rins.io` (data files),
:mod:`~optinav.rins.process` (alignment → strapdown → C_s^n), :mod:`~optinav.rins.calibrate`
(methods none / axis / pso / lm, observability, RESULT.json).
"""

from optinav.rins.calibrate import RinsCalibration, calibrate, prepare
from optinav.rins.io import read_rins, write_rins
from optinav.rins.model import PARAM_NAMES, residual_jacobian, residuals, vehicle_attitude
from optinav.rins.simulate import RinsData, simulate

__all__ = [
    "PARAM_NAMES",
    "residuals",
    "residual_jacobian",
    "vehicle_attitude",
    "RinsData",
    "simulate",
    "read_rins",
    "write_rins",
    "RinsCalibration",
    "calibrate",
    "prepare",
]
