"""One recording of a multi-position session, as :mod:`optinav.batch` runs it (registry: ``multipos``)."""

from __future__ import annotations

import math

from optinav.multipos.calibrate import FileOptions, calibrate_data, local_gravity, read_session_file
from optinav.multipos.result import CalibrationResult


def check(options: FileOptions) -> None:
    """The options' own checks and the site (gravity or latitude/height), once before a batch."""
    options.check()
    local_gravity(
        options.gravity, None if options.lat_deg is None else math.radians(options.lat_deg), options.height_m
    )  # FileOptions holds the CLI's degrees


def run_unit(path, options: FileOptions, reference: bool = False) -> tuple[CalibrationResult, dict]:
    """Read and calibrate ``path`` (what ``optinav calibrate accel`` does); the result and the table columns
    beyond its parameters: raw units, gravity (m/s²), samples, poses, residual RMS (m/s²), χ² and dof of the
    accelerometer fit, RMS of the gyro's carried gravity directions (rad) (None for the closed-form Ferraris
    method, which has none)."""
    data = read_session_file(path, options)
    res = calibrate_data(data, options, source=str(path))
    acc = res.accelerometer
    chi2 = acc.get("chi2") if acc is not None else None
    dof = acc.get("dof") if acc is not None else None
    gyr = res.gyroscope
    return res, {
        "acc_unit": res.units["accelerometer_raw"],
        "gyr_unit": res.units.get("gyroscope_raw"),
        "gravity_m_s2": res.gravity,
        "n_samples": len(data.t),
        "n_poses": len(res.static_intervals),
        "residual_rms_m_s2": res.residual_rms,
        "pose_residual_rms_m_s2": res.quality["pose_residual_rms"],
        "chi2": chi2,
        "dof": dof,
        "reduced_chi2": chi2 / dof if chi2 is not None and dof and math.isfinite(chi2) else None,
        "gyr_residual_rms_rad": None if gyr is None or _closed_form(res) else gyr["residual_rms_rad"],
    }


def _closed_form(res: CalibrationResult) -> bool:
    return res.method == "ferraris"
