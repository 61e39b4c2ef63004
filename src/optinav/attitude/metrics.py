"""Attitude error metrics: BROAD's inclination/heading split and per-angle statistics (the paper's tables).

BROAD (Laidig et al. 2021, Data 6(7):72, broad_utils.py): error quaternion in the earth frame
``q_err = q_est ⊗ q_ref*``; total = 2·acos|w|, heading = 2·atan|z/w|, inclination = 2·acos√(w² + z²),
with z the vertical axis of the navigation frame (ENU or NED alike). A constant heading offset between the
estimate's and the reference's navigation frames is pure heading error, so the inclination is free of it.
"""

from __future__ import annotations

import numpy as np

from optinav.core.rotations import DEFAULT_FRAME, euler_from_quat, frame_name, quat_conjugate, quat_multiply
from optinav.core.validate import as_float_array
from optinav.errors import OptinavError

__all__ = [
    "earth_error_quaternion",
    "inclination_error",
    "heading_error",
    "total_error",
    "euler_errors",
    "error_statistics",
    "rmse",
]


def _pair(q_est, q_ref) -> tuple[np.ndarray, np.ndarray]:
    a = as_float_array(q_est, "q_est", last_dims=(4,), finite=False)
    b = as_float_array(q_ref, "q_ref", last_dims=(4,), finite=False)
    if a.shape != b.shape:
        raise OptinavError(f"q_est {a.shape} and q_ref {b.shape} differ in shape", "pass aligned quaternions")
    return a / np.linalg.norm(a, axis=-1, keepdims=True), b / np.linalg.norm(b, axis=-1, keepdims=True)


def earth_error_quaternion(q_est, q_ref) -> np.ndarray:
    """q_est ⊗ q_ref* (navigation-frame error rotation); NaN rows stay NaN."""
    a, b = _pair(q_est, q_ref)
    return quat_multiply(a, quat_conjugate(b))


def inclination_error(q_est, q_ref) -> np.ndarray:
    """Inclination (tilt) error, rad: 2·acos√(w² + z²) of the earth-frame error quaternion."""
    e = earth_error_quaternion(q_est, q_ref)
    return 2.0 * np.arccos(np.clip(np.sqrt(e[..., 0] ** 2 + e[..., 3] ** 2), 0.0, 1.0))


def heading_error(q_est, q_ref) -> np.ndarray:
    """Heading error, rad in [0, π]: 2·atan|z/w| of the earth-frame error quaternion."""
    e = earth_error_quaternion(q_est, q_ref)
    return 2.0 * np.arctan(np.abs(e[..., 3] / e[..., 0]))


def total_error(q_est, q_ref) -> np.ndarray:
    """Total attitude error, rad: 2·acos|w|."""
    e = earth_error_quaternion(q_est, q_ref)
    return 2.0 * np.arccos(np.clip(np.abs(e[..., 0]), 0.0, 1.0))


def euler_errors(q_est, q_ref, frame: str = DEFAULT_FRAME) -> np.ndarray:
    """[roll, pitch, yaw] of the estimate minus the reference (rad, wrapped to (−π, π]), shape (N, 3).

    Rows where either quaternion is NaN (a reference that lost tracking) stay NaN, as in the other metrics."""
    a, b = _pair(q_est, q_ref)
    conv = frame_name(frame)
    ok = np.isfinite(a).all(axis=-1) & np.isfinite(b).all(axis=-1)
    d = np.full(a.shape[:-1] + (3,), np.nan)
    d[ok] = euler_from_quat(a[ok], conv) - euler_from_quat(b[ok], conv)
    return np.angle(np.exp(1j * d))


def rmse(x, mask=None) -> float:
    """Root mean square over finite entries (and ``mask``)."""
    x = np.asarray(x, dtype=float)
    ok = np.isfinite(x) if mask is None else (np.isfinite(x) & np.asarray(mask, bool))
    if not np.any(ok):
        raise OptinavError("no finite samples to average", "check the reference data and the mask")
    return float(np.sqrt(np.mean(x[ok] ** 2)))


def error_statistics(err) -> dict[str, np.ndarray]:
    """Per-column mean, std, max |·| and RMS of errors (N, k) — the quantities of the paper's Tables 1–3."""
    e = np.asarray(err, dtype=float)
    return {
        "mean": np.nanmean(e, axis=0),
        "std": np.nanstd(e, axis=0),
        "max_abs": np.nanmax(np.abs(e), axis=0),
        "rms": np.sqrt(np.nanmean(e**2, axis=0)),
    }
