"""Processing chain of a rotational-INS recording: checks → alignment → strapdown → ``C_s^n(t)``.

Alignment on the initial rest (both encoders still, at most ``align_s`` s): analytic coarse alignment then the
Kalman fine alignment of :mod:`optinav.core.alignment`. Strapdown: :func:`optinav.core.strapdown.attitude_update`
with the Earth rate as the navigation-frame rate (static base: ``ω_in^n = ω_ie^n``, no transport rate),
"previous"-sample coning correction. ``C_s^n`` is computed once; calibrations only re-evaluate the gimbal chain.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from optinav.core import earth as _earth
from optinav.core.alignment import coarse_alignment, fine_alignment
from optinav.core.rotations import dcm_from_quat
from optinav.core.strapdown import attitude_update
from optinav.core.validate import as_float_array, check_timestamps
from optinav.errors import OptinavError

__all__ = ["SensorAttitude", "check_data", "sensor_attitude_from_imu", "motion_mask"]

#: an encoder step above this (rad) between samples counts as motion
MOTION_STEP = np.radians(0.01)


@dataclasses.dataclass
class SensorAttitude:
    """IMU attitude ``c_s_n`` (M, 3, 3) at epochs ``t`` (M,) with the encoder angles there (rad).

    ``index``: the data rows of the epochs; epoch 0 is the end of the alignment (the navigation start).
    """

    t: np.ndarray
    c_s_n: np.ndarray
    alpha: np.ndarray
    beta: np.ndarray
    index: np.ndarray
    align_end: float
    align_std: np.ndarray


def motion_mask(angle, step: float = MOTION_STEP) -> np.ndarray:
    """Rows where an encoder angle changed by more than ``step`` rad since the previous row."""
    d = np.abs(np.diff(np.asarray(angle, float), prepend=angle[0]))
    return d > step


def check_data(data) -> None:
    """Bad-input checks of issue 4, item 8 (one-line OptinavErrors; see docs/methods/rins.md)."""
    t = check_timestamps(data.t, "time", min_count=10)
    n = t.size
    dth = as_float_array(data.dtheta, "dtheta (gyro increments)", last_dims=(3,))
    dv = as_float_array(data.dv, "dv (accelerometer increments)", last_dims=(3,))
    for name, a in (("alpha (inner encoder)", data.alpha), ("beta (outer encoder)", data.beta)):
        a = as_float_array(a, name)
        if a.shape != (n,):
            raise OptinavError(
                f"{name} has {a.size} samples for {n} IMU samples (sample-rate mismatch)",
                "resample the encoder angles to the IMU epochs (e.g. numpy.interp) first",
            )
    if dth.shape != (n, 3) or dv.shape != (n, 3):
        raise OptinavError(
            f"dtheta {dth.shape} / dv {dv.shape} do not match {n} time stamps", "give one increment row per time stamp"
        )
    dt = np.diff(t)
    if np.max(dt) > 1.5 * np.median(dt):
        k = int(np.argmax(dt))
        raise OptinavError(
            f"gap of {dt[k]:.4g} s at t = {t[k]:.6g} s (nominal step {np.median(dt):.4g} s)",
            "pass an uninterrupted recording (increments over a gap are not defined)",
        )
    rate = 1.0 / np.median(dt)
    for name, a in (("alpha (inner encoder)", data.alpha), ("beta (outer encoder)", data.beta)):
        a = np.asarray(a, float)
        d = np.abs(np.diff(a))
        # fast part of the moves: the angle changes by > 8 motion steps over ±4 samples
        fast = np.abs(a[8:] - a[:-8]) > 8 * MOTION_STEP
        inside = np.flatnonzero(fast) + 4
        inside = inside[inside < d.size]
        if inside.size > 20:
            held = float(np.mean(d[inside] == 0.0))
            if held > 0.3:
                raise OptinavError(
                    f"{name} holds its value on {held:.0%} of the samples while it turns: it is "
                    f"sampled slower than the IMU ({rate:.4g} Hz)",
                    "interpolate the encoder angles to the IMU epochs (sample-rate mismatch)",
                )


#: smallest latitude disagreement (deg) reported; gyro bias of a navigation-grade IMU moves the measured
#: latitude by far less (0.01 °/h against 15 °/h of Earth rate: 0.04°)
LAT_TOL_DEG = 2.0


def measured_latitude(dth, dv, span: float) -> tuple[float, float]:
    """Latitude (rad) from the Earth rate the gyros see at rest: the angle between the mean rate and the
    horizontal plane, up from the mean specific force; and its 1σ (rad) from the gyro noise (first differences of
    the increments, so the constant Earth rate drops out). ``dth`` (rad), ``dv`` (m/s) over ``span`` seconds."""
    w = dth.sum(0) / span
    up = dv.sum(0) / np.linalg.norm(dv.sum(0))
    w_up = float(w @ up)
    w_h = float(np.linalg.norm(w - w_up * up))
    noise = np.std(np.diff(dth, axis=0), axis=0).max() / np.sqrt(2) * np.sqrt(len(dth)) / span
    return float(np.arctan2(w_up, w_h)), float(noise / _earth.WGS84.omega_ie)


def latitude_check(dth, dv, span: float, lat: float) -> None:
    """The declared latitude ``lat`` (rad) must agree with the one the gyros measure at rest (a wrong latitude
    misplaces the Earth rate removed by the strapdown and every angle comes out wrong)."""
    if not -np.pi / 2 <= lat <= np.pi / 2:
        raise OptinavError(f"latitude {np.degrees(lat):.6g}° is outside [-90°, 90°]", "pass --lat DEG (north +)")
    meas, sd = measured_latitude(dth, dv, span)
    tol = max(np.radians(LAT_TOL_DEG), 5 * sd)
    if sd < np.radians(10) and abs(meas - lat) > tol:
        raise OptinavError(
            f"the latitude {np.degrees(lat):.4g}° disagrees with the {np.degrees(meas):.4g}° ± "
            f"{np.degrees(sd):.2g}° the gyros measure from the Earth rate at rest",
            "check --lat (north positive) or the file's lat_deg",
        )


def _rest_rows(data, align_s) -> int:
    """Number of initial rows with both encoders still (capped to ``align_s`` seconds)."""
    moving = motion_mask(data.alpha) | motion_mask(data.beta)
    first = int(np.argmax(moving)) if moving.any() else data.t.size
    if align_s is not None:
        first = min(first, int(np.searchsorted(data.t, data.t[0] + align_s)))
    return first


def sensor_attitude_from_imu(
    data, *, align_s: float | None = None, coning: str = "previous", fine: bool = True
) -> SensorAttitude:
    """Align on the initial rest, then integrate ``C_s^n`` over the rest of the recording.

    data: :class:`~optinav.rins.simulate.RinsData`. align_s: longest alignment window (s; default the whole
    initial rest). Returns the attitude from the last alignment row on.
    """
    check_data(data)
    t = np.asarray(data.t, float)
    dt = np.diff(t)
    step = float(np.median(dt))
    k_a = _rest_rows(data, align_s)
    if k_a * step < 10.0:
        raise OptinavError(
            f"only {k_a * step:.3g} s of rest before the first gimbal move",
            "record at least 60 s (the paper: 600 s) static with both gimbals still first",
        )
    if k_a >= t.size - 2:
        raise OptinavError(
            "the gimbals never move after the alignment (no gimbal motion)",
            "nothing can be calibrated: record a rotation scheme turning both axes",
        )
    # row k integrates over (t[k], t[k+1]]; t[m] is the last epoch with both encoders still, so the alignment
    # uses rows 0..m−1 (epochs t[0..m]) and the strapdown starts at t[m]
    m = k_a - 1
    ep = t[: m + 1]
    dth, dv = data.dtheta[:m], data.dv[:m]
    span = ep[-1] - ep[0]
    # the encoders see a move start a little after the gyros (slow start of a rate profile): leave 2 s out
    k_lat = max(2, m - int(round(2.0 / step)))
    latitude_check(dth[:k_lat], dv[:k_lat], k_lat * step, data.lat)
    coarse = coarse_alignment(dv.sum(0) / span, dth.sum(0) / span, data.lat, data.height_m, "enu")
    if fine:
        al = fine_alignment(
            ep,
            dth,
            dv,
            data.lat,
            data.height_m,
            frame="enu",
            q0=coarse.q_b_n,
            gyro_white=5e-7,
            acc_white=5e-5,
            gyro_bias_std=1e-7,
            acc_bias_std=3e-4,
        )
    else:
        al = coarse
    w_ie = _earth.earth_rate(data.lat, "enu")
    # rows m..N−2 carry the attitude from t[m] to t[N−1] (the last row ends after the last encoder epoch)
    q = attitude_update(al.q_b_n, data.dtheta[m:-1], coning=coning, omega_in_n=w_ie, dt=dt[m:])
    idx = np.arange(m, t.size)
    return SensorAttitude(
        t=t[idx],
        c_s_n=dcm_from_quat(q),
        alpha=np.asarray(data.alpha, float)[idx],
        beta=np.asarray(data.beta, float)[idx],
        index=idx,
        align_end=float(t[m]),
        align_std=np.asarray(al.attitude_std, float),
    )
