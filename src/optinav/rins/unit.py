"""One rotational-INS recording, as :mod:`optinav.batch` runs it (registry: ``rins``)."""

from __future__ import annotations

import dataclasses
from pathlib import Path
import math

import numpy as np

from optinav.core.progress import step
from optinav.errors import OptinavError
from optinav.rins.calibrate import METHODS, RinsCalibration, calibrate, prepare
from optinav.rins.io import read_rins
from optinav.rins.model import vehicle_attitude
from optinav.rins.process import sensor_attitude_from_imu


@dataclasses.dataclass
class RinsOptions:
    """The options of ``optinav calibrate rins``: ``method``; ``lat_deg`` latitude in degrees (None: from the
    file); ``align_s`` longest alignment window in s (None: the initial rest); ``residual_rate_hz`` epochs per
    second of the attitude residuals; ``seed`` of PSO."""

    method: str = "lm"
    lat_deg: float | None = None
    align_s: float | None = None
    residual_rate_hz: float = 10.0
    seed: int = 0


def check(options: RinsOptions) -> None:
    if options.method not in METHODS:
        raise OptinavError(f"unknown method {options.method!r}", f"use one of {', '.join(METHODS)}")
    if not (math.isfinite(options.residual_rate_hz) and options.residual_rate_hz > 0):
        raise OptinavError(
            f"--residual-rate {options.residual_rate_hz!r} is not a positive rate",
            "give epochs per second, e.g. --residual-rate 10",
        )


def read(path, options: RinsOptions):
    """The recording at ``path`` (the latitude of ``options`` when given, else the file's)."""
    return read_rins(path, lat=None if options.lat_deg is None else math.radians(options.lat_deg))


def run_unit(path, options: RinsOptions, reference: bool = False) -> tuple[RinsCalibration, dict]:
    """Read and calibrate ``path`` (what ``optinav calibrate rins`` does); extra columns: samples, the RMS of
    the extracted attitude change before/after compensation (deg, [roll, pitch, yaw])."""
    step("read")
    data = read(path, options)
    step("prepare")
    prep = prepare(data, residual_rate=options.residual_rate_hz, align_s=options.align_s)
    step(f"fit ({options.method})")
    res = calibrate(method=options.method, prep=prep, rng=options.seed, source=str(path))
    extra = {"n_samples": int(data.t.size)}
    for when, v in (("before", res.rmse_before_deg), ("after", res.rmse_after_deg)):
        extra.update({f"rmse_{when}_{ax}_deg": float(x) for ax, x in zip(("roll", "pitch", "yaw"), v)})
    return res, extra


def compensated_attitude(angles, path, options: RinsOptions | None = None):
    """The vehicle attitude of a recording with the gimbal non-orthogonality compensated (Li et al. 2023,
    eq. 6). On a static base the true vehicle attitude is constant, so what it still changes is the residual
    error (eqs. 12-14).

    Parameters
    ----------
    angles : (6,) array_like
        theta_x..z, eta_x..z [rad]: a result's :attr:`~optinav.rins.calibrate.RinsCalibration.p` (the
        unobservable angles at the values it used), or zeros for the uncompensated attitude.
    path : str or Path
        The recording (as :func:`optinav.rins.io.read_rins` reads it).
    options : RinsOptions, optional
        Latitude ``lat_deg`` [deg] and alignment window ``align_s`` [s]; default the file's and the initial rest.

    Returns
    -------
    t : (T,) ndarray
        Epochs from the navigation start (the end of the alignment) [s].
    C_b_n : (T, 3, 3) ndarray
        Vehicle attitude, n = ENU.
    """
    o = options or RinsOptions()
    sa = sensor_attitude_from_imu(read(path, o), align_s=o.align_s)
    return sa.t, vehicle_attitude(sa.c_s_n, sa.alpha, sa.beta, angles)


def apply_file(result_path, data_path, out, options: RinsOptions | None = None) -> str:
    """``optinav apply`` for a rins result: write ``out`` (CSV) with t (s), the compensated vehicle attitude
    q_b_n (w, x, y, z; n = ENU) and its roll, pitch, yaw in degrees; returns the one-line account."""
    from optinav.core.files import write_csv
    from optinav.core.rotations import euler_from_dcm, quat_from_dcm

    if Path(out).suffix.lower() not in (".csv", ".txt"):
        raise OptinavError(f"--out {out}: this result's output is a CSV table", "name it FILE.csv")
    res = RinsCalibration.from_json(result_path)
    t, C_b_n = compensated_attitude(res.p, data_path, options)
    write_csv(
        out,
        np.column_stack([t, quat_from_dcm(C_b_n), np.degrees(euler_from_dcm(C_b_n, "enu"))]),
        "t,qw,qx,qy,qz,roll_deg,pitch_deg,yaw_deg",
        "%.12g",
    )
    return (
        f"wrote the vehicle attitude of {t.size} epochs to {out}, the gimbal non-orthogonality of "
        f"{res.method} compensated (q_b_n ENU, degrees)"
    )
