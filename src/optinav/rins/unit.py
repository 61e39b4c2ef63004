"""One rotational-INS recording, as :mod:`optinav.batch` runs it (registry: ``rins``)."""

from __future__ import annotations

import dataclasses
from pathlib import Path
import math

import numpy as np

from optinav.core.progress import step
from optinav.errors import OptinavError
from optinav.rins.calibrate import METHODS, RinsCalibration, calibrate, prepare
from optinav.core.rotations import dcm_from_quat
from optinav.rins.io import rins_source
from optinav.rins.model import vehicle_attitude
from optinav.rins.process import strapdown_blocks, survey


@dataclasses.dataclass
class RinsOptions:
    """The options of ``optinav calibrate rins``: ``method``; ``lat_deg`` latitude in degrees (None: from the
    file); ``align_s`` longest alignment window in s (None: the initial rest); ``residual_rate_hz`` epochs per
    second of the attitude residuals; ``seed`` of PSO; ``gyro_misalignment_arcsec`` (″) and ``gyro_scale_ppm``
    (ppm): 1σ of the gyro triad's uncalibrated errors propagated into the std (default the "rlg-nav" preset's)."""

    method: str = "lm"
    lat_deg: float | None = None
    align_s: float | None = None
    residual_rate_hz: float = 10.0
    seed: int = 0
    gyro_misalignment_arcsec: float = 5.0
    gyro_scale_ppm: float = 2.0


def check(options: RinsOptions) -> None:
    if options.method not in METHODS:
        raise OptinavError(f"unknown method {options.method!r}", f"use one of {', '.join(METHODS)}")
    if not (math.isfinite(options.residual_rate_hz) and options.residual_rate_hz > 0):
        raise OptinavError(
            f"--residual-rate {options.residual_rate_hz!r} is not a positive rate",
            "give epochs per second, e.g. --residual-rate 10",
        )


def read(path, options: RinsOptions):
    """The recording at ``path`` as blocks read from the file each pass (the latitude of ``options`` when given,
    else the file's): :class:`optinav.rins.io.RinsFile`."""
    return rins_source(path, lat=None if options.lat_deg is None else math.radians(options.lat_deg))


def run_unit(path, options: RinsOptions, reference: bool = False) -> tuple[RinsCalibration, dict]:
    """Calibrate ``path`` block by block (what ``optinav calibrate rins`` does); extra columns: samples, the RMS
    of the extracted attitude change before/after compensation (deg, [roll, pitch, yaw])."""
    step("prepare")
    gyro = {
        "gyro_misalignment": math.radians(options.gyro_misalignment_arcsec / 3600),
        "gyro_scale": options.gyro_scale_ppm * 1e-6,
    }
    prep = prepare(read(path, options), residual_rate=options.residual_rate_hz, align_s=options.align_s, **gyro)
    step(f"fit ({options.method})")
    res = calibrate(method=options.method, prep=prep, rng=options.seed, source=str(path), **gyro)
    res.align_s = options.align_s
    extra = {"n_samples": int(prep.align.n)}
    for when, v in (("before", res.rmse_before_deg), ("after", res.rmse_after_deg)):
        extra.update({f"rmse_{when}_{ax}_deg": float(x) for ax, x in zip(("roll", "pitch", "yaw"), v)})
    return res, extra


def compensated_blocks(angles, path, options: RinsOptions | None = None):
    """The vehicle attitude of a recording with the gimbal non-orthogonality compensated (Li et al. 2023,
    eq. 6), block by block (two passes over the file: alignment, then strapdown). On a static base the true
    vehicle attitude is constant, so what it still changes is the residual error (eqs. 12-14).

    Parameters
    ----------
    angles : (6,) array_like
        theta_x..z, eta_x..z [rad]: a result's :attr:`~optinav.rins.calibrate.RinsCalibration.p` (the
        unobservable angles at the values it used), or zeros for the uncompensated attitude.
    path : str, Path, RinsData or block source
        The recording (:func:`optinav.rins.io.rins_source`).
    options : RinsOptions, optional
        Latitude ``lat_deg`` [deg] and alignment window ``align_s`` [s]; default the file's and the initial rest.

    Yields
    ------
    t : (k,) ndarray
        Epochs from the navigation start (the end of the alignment) on [s].
    C_b_n : (k, 3, 3) ndarray
        Vehicle attitude, n = ENU.
    """
    o = options or RinsOptions()
    src = read(path, o)
    al = survey(src, align_s=o.align_s)
    for nb in strapdown_blocks(src, al):
        yield nb.t, vehicle_attitude(dcm_from_quat(nb.q), nb.alpha, nb.beta, angles)


def compensated_attitude(angles, path, options: RinsOptions | None = None):
    """:func:`compensated_blocks` gathered: ``t`` (T,) [s] and ``C_b_n`` (T, 3, 3) of the whole recording."""
    parts = list(compensated_blocks(angles, path, options))
    return np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])


#: the header of the table ``optinav apply`` writes for this system (how it knows its own output again)
APPLY_COLUMNS = "t,qw,qx,qy,qz,roll_deg,pitch_deg,yaw_deg"


def apply_file(result_path, data_path, out, options: RinsOptions | None = None) -> str:
    """``optinav apply`` for a rins result: write ``out`` (CSV, block by block) with t (s), the compensated vehicle
    attitude q_b_n (w, x, y, z; n = ENU) and its roll, pitch, yaw in degrees; returns the one-line account."""
    from optinav.core.files import csv_writer
    from optinav.core.rotations import euler_from_dcm, quat_from_dcm

    if Path(out).suffix.lower() not in (".csv", ".txt"):
        raise OptinavError(f"--out {out}: this result's output is a CSV table", "name it FILE.csv")
    res = RinsCalibration.from_json(result_path)
    n = 0
    with csv_writer(out, APPLY_COLUMNS, "%.12g") as write:
        for t, C_b_n in compensated_blocks(res.p, data_path, options):
            write(np.column_stack([t, quat_from_dcm(C_b_n), np.degrees(euler_from_dcm(C_b_n, "enu"))]))
            n += t.size
    return (
        f"wrote the vehicle attitude of {n} epochs to {out}, the gimbal non-orthogonality of "
        f"{res.method} compensated (q_b_n ENU, degrees)"
    )
