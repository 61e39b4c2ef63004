"""Static initial alignment: analytic coarse alignment and Kalman-filter fine alignment.

Both work on a static base at a known latitude, in the navigation frame ``frame`` ("ned", the default, or "enu").

Coarse alignment (double-vector / TRIAD): the body-frame specific force ``f_b`` (≈ −C_n^b g^n) and angular
rate ``ω_b`` (≈ C_n^b ω_ie^n) averaged over the window give an up, an east and a north direction in both
frames, hence ``C_b^n``. First-order errors (Titterton & Weston 2004, §10.2; Yan Gongmin, *Inertial navigation*,
§7.1), with biases ∇ (accelerometer) and ε (gyro) projected on the navigation axes:
level tilt ≈ ∇_horizontal / g, heading ≈ −ε_E / (ω_ie cos L) + ∇_E tan L / g (ENU components; the steady state
of φ̇ = −ω_ie × φ − ε^n).

Fine alignment: a 12-state error-state Kalman filter [φ, δv, ε, ∇] (φ-angle model,
``C_b^n(computed) = (I − [φ×]) C_b^n(true)``) with zero-velocity measurements and full feedback, on a static
base (Savage 2000; Titterton & Weston §10.3). The east gyro bias and the horizontal accelerometer biases are not
observable on a static base, so the filter's attitude converges to the same theoretical limits
(:func:`alignment_limits`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from optinav.core import earth as _earth
from optinav.core.results import Result, nested_kwargs, register_legacy
from optinav.core.rotations import (
    DEFAULT_FRAME,
    _cross,
    _dcm_of_quats,
    _quat_of_rotvec,
    frame_name,
    dcm_from_quat,
    euler_from_dcm,
    quat_from_dcm,
    quat_multiply,
    rotvec_from_dcm,
    skew,
)
from optinav.core.strapdown import attitude_update
from optinav.core.validate import as_float_array, check_positive, check_timestamps
from optinav.errors import OptinavError


@dataclass
class AlignmentResult(Result):
    """Attitude from a static alignment, with its predicted accuracy.

    Version 2 renamed ``accel_bias``/``accel_bias_std`` to ``acc_bias``/``acc_bias_std`` (version-1 files still load).
    """

    SCHEMA = "optinav.alignment"
    VERSION = 2
    method: str = field(metadata={"unit": "-"})
    frame: str = field(metadata={"unit": "-"})
    q_b_n: np.ndarray = field(metadata={"unit": "1"})
    euler: np.ndarray = field(metadata={"unit": "rad"})  #: [roll, pitch, yaw] in the frame's convention
    attitude_std: np.ndarray = field(metadata={"unit": "rad"})  #: 1σ of φ (navigation axes), NaN if unknown
    gyro_bias: np.ndarray = field(default_factory=lambda: np.full(3, np.nan), metadata={"unit": "rad/s"})
    gyro_bias_std: np.ndarray = field(default_factory=lambda: np.full(3, np.nan), metadata={"unit": "rad/s"})
    acc_bias: np.ndarray = field(default_factory=lambda: np.full(3, np.nan), metadata={"unit": "m/s^2"})
    acc_bias_std: np.ndarray = field(default_factory=lambda: np.full(3, np.nan), metadata={"unit": "m/s^2"})
    history_t: np.ndarray = field(default_factory=lambda: np.zeros(0), metadata={"unit": "s"})
    history_euler: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)), metadata={"unit": "rad"})
    history_attitude_std: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)), metadata={"unit": "rad"})

    @property
    def C_b_n(self) -> np.ndarray:
        """Attitude ``C_b^n`` from ``q_b_n``."""
        return dcm_from_quat(self.q_b_n)


register_legacy(
    AlignmentResult,
    AlignmentResult.SCHEMA,
    1,
    lambda d: nested_kwargs(AlignmentResult, d, {"accel_bias": "acc_bias", "accel_bias_std": "acc_bias_std"}),
)  # old names


def _axes(up, rate):
    """Orthonormal (east, north, up) triad from an up vector and the Earth-rate vector in the same frame."""
    u = up / np.linalg.norm(up)
    e = np.cross(rate, u)
    ne = np.linalg.norm(e)
    if not ne > 1e-3 * np.linalg.norm(rate) or not ne > 0:
        raise OptinavError(
            "Earth rate is parallel to gravity (latitude ±90° or no rotation seen)",
            "coarse heading is undefined here; give the heading from another source",
        )
    e = e / ne
    return np.column_stack([e, np.cross(u, e), u])


def coarse_alignment(acc, gyr, lat, height_m=0.0, frame=DEFAULT_FRAME, earth="wgs84") -> AlignmentResult:
    """Analytic static alignment from mean specific force and angular rate.

    Parameters
    ----------
    acc : (3,) or (N, 3) array
        Specific force [m/s^2], window mean or samples (averaged here).
    gyr : (3,) or (N, 3) array
        Angular rate ω_ib^b [rad/s], window mean or samples.
    lat : float
        Latitude [rad].
    height_m : float
        Height above the ellipsoid [m].
    frame : str
        ``"enu"`` or ``"ned"``.
    earth : str or EarthConstants
        Constant set.

    Returns
    -------
    AlignmentResult
        ``q_b^n``, Euler angles [rad].
    """
    h, frame = height_m, frame_name(frame)
    f = as_float_array(acc, "acc", last_dims=(3,)).reshape(-1, 3).mean(axis=0)
    w = as_float_array(gyr, "gyr", last_dims=(3,)).reshape(-1, 3).mean(axis=0)
    g = float(_earth.gravity(lat, h, earth))
    nf = np.linalg.norm(f)
    if not 0.5 * g < nf < 1.5 * g:
        raise OptinavError(
            f"mean specific force {nf:.3f} m/s² is far from gravity {g:.3f} m/s²",
            "check the accelerometer units (m/s² expected) and that the base was static",
        )
    w_n = _earth.earth_rate(lat, frame, earth)
    up_n = -_earth.gravity_vector(lat, h, frame, earth)
    a_b = _axes(f, w)  # columns: east, north, up in body coordinates
    a_n = _axes(up_n, w_n)
    c_b_n = a_n @ a_b.T
    q = quat_from_dcm(c_b_n)
    return AlignmentResult("coarse", frame, q, euler_from_dcm(c_b_n, frame), np.full(3, np.nan))


def alignment_limits(gyro_bias_n, acc_bias_n, lat, height_m=0.0, frame=DEFAULT_FRAME, earth="wgs84") -> np.ndarray:
    """Theoretical static-alignment errors φ caused by biases given in the n frame.

    First order: in ENU, φ_E = −∇_N/g, φ_N = ∇_E/g, φ_U = −ε_E/(ω_ie cos L) + ∇_E tan L / g, with
    ``C_b^n(computed) = (I − [φ×]) C_b^n(true)``. NED inputs/outputs are converted.

    Parameters
    ----------
    gyro_bias_n : (3,) array
        Gyro bias ε in navigation axes [rad/s].
    acc_bias_n : (3,) array
        Accelerometer bias ∇ in navigation axes [m/s^2].
    lat : float
        Latitude L [rad].
    height_m : float
        Height above the ellipsoid [m].
    frame : str
        ``"enu"`` or ``"ned"``.
    earth : str or EarthConstants
        Constant set.

    Returns
    -------
    (3,) ndarray
        φ in navigation axes [rad].
    """
    frame = frame_name(frame)
    e = _earth.constants(earth)
    g = float(_earth.gravity(lat, height_m, earth))
    eps = np.asarray(gyro_bias_n, dtype=float)
    nab = np.asarray(acc_bias_n, dtype=float)
    if frame == "ned":  # to ENU
        eps, nab = eps[[1, 0, 2]] * [1, 1, -1], nab[[1, 0, 2]] * [1, 1, -1]
    phi = np.array([-nab[1] / g, nab[0] / g, -eps[0] / (e.omega_ie * np.cos(lat)) + nab[0] * np.tan(lat) / g])
    if frame == "ned":
        phi = phi[[1, 0, 2]] * [1, 1, -1]
    return phi


def _error_model_attitude(F, G, c_b_n) -> None:
    """The attitude-dependent blocks of the static φ-angle error model (``C_b^n`` in F's attitude/bias couplings
    and in the noise input G), written into ``F`` and ``G`` of :func:`_error_model_static` in place."""
    F[0:3, 6:9] = -c_b_n
    F[3:6, 9:12] = c_b_n
    G[0:3, 0:3] = -c_b_n
    G[3:6, 3:6] = c_b_n


def _error_model_static(lat, h, frame, earth):
    """Continuous-time F (12×12) and noise input G (12×6) of the static φ-angle error model without their
    attitude blocks (zero until :func:`_error_model_attitude` fills them): Earth rate, transport rate, gravity."""
    w_ie = _earth.earth_rate(lat, frame, earth)
    f_n = -_earth.gravity_vector(lat, h, frame, earth)
    rm, rn = _earth.radii(lat, h, earth)
    t = np.tan(lat)
    # ∂(ω_en^n)/∂(δv): transport rate is linear in velocity
    if frame == "enu":
        m_av = np.array([[0, -1 / rm, 0], [1 / rn, 0, 0], [t / rn, 0, 0]])
    else:
        m_av = np.array([[0, 1 / rn, 0], [-1 / rm, 0, 0], [0, -t / rn, 0]])
    F = np.zeros((12, 12))
    F[0:3, 0:3] = -skew(w_ie)
    F[0:3, 3:6] = m_av
    F[3:6, 0:3] = skew(f_n)
    F[3:6, 3:6] = -2 * skew(w_ie)
    return F, np.zeros((12, 6))


def fine_alignment(
    t,
    dtheta,
    dv,
    lat,
    height_m=0.0,
    *,
    frame=DEFAULT_FRAME,
    earth="wgs84",
    q0=None,
    gyro_white=1e-6,
    acc_white=1e-4,
    gyro_bias_std=1e-6,
    acc_bias_std=1e-3,
    initial_attitude_std=(1e-3, 1e-3, 1e-2),
    velocity_noise=None,
    kf_interval=0.1,
    gyro_bias_instability=0.0,
    gyro_bias_tau=np.inf,
    acc_bias_instability=0.0,
    acc_bias_tau=np.inf,
) -> AlignmentResult:
    """Kalman-filter fine alignment on a static base from increments.

    The filter steps every ``kf_interval`` on summed increments (the base is static, so sums over 0.1 s lose
    nothing). With ``*_bias_instability`` and ``*_bias_tau`` the bias states are first-order Gauss–Markov
    (ḃ = −b/τ + w, PSD 2σ²/τ) instead of random constants. Model it when the unit drifts: gyrocompassing reads
    heading from the tilt rate, and an accelerometer bias drifting by ∇/τ looks like a heading error of
    (∇/τ)/(g ω_ie cos L) to a filter that believes the bias constant.

    Parameters
    ----------
    t : (N+1,) array
        Epochs [s]; increments over (t[k], t[k+1]].
    dtheta : (N, 3) array
        Body angular increments [rad].
    dv : (N, 3) array
        Body velocity increments [m/s].
    lat : float
        Latitude [rad].
    height_m : float
        Height above the ellipsoid [m].
    frame : str
        ``"enu"`` or ``"ned"``.
    earth : str or EarthConstants
        Constant set.
    q0 : (4,) array or None
        Initial ``q_b^n`` [-]; None: coarse alignment on the data.
    gyro_white : float
        Gyro ARW [rad/√s].
    acc_white : float
        Accelerometer VRW [m/s/√s].
    gyro_bias_std : float
        Prior 1σ of the gyro bias [rad/s].
    acc_bias_std : float
        Prior 1σ of the accelerometer bias [m/s^2].
    initial_attitude_std : (3,) array_like
        Prior 1σ of the initial attitude error, navigation axes [rad].
    velocity_noise : float or None
        1σ of the zero-velocity measurement [m/s]; None: from the VRW over one filter step.
    kf_interval : float
        Filter step [s].
    gyro_bias_instability : float
        Gauss–Markov σ of the gyro bias [rad/s].
    gyro_bias_tau : float
        Its correlation time [s].
    acc_bias_instability : float
        Gauss–Markov σ of the accelerometer bias [m/s^2].
    acc_bias_tau : float
        Its correlation time [s].

    Returns
    -------
    AlignmentResult
        ``q_b^n``, Euler angles [rad], attitude 1σ [rad] and the estimated biases [rad/s, m/s^2].
    """
    h, frame = height_m, frame_name(frame)
    t = check_timestamps(t, "t")
    dth = as_float_array(dtheta, "dtheta", last_dims=(3,))
    dvv = as_float_array(dv, "dv", last_dims=(3,))
    if dth.shape != (t.size - 1, 3) or dvv.shape != dth.shape:
        raise OptinavError(
            f"dtheta {dth.shape} and dv {dvv.shape} must be ({t.size - 1}, 3) for {t.size} epochs",
            "pass one increment per interval between epochs",
        )
    check_positive(kf_interval, "kf_interval")
    taus = np.array([gyro_bias_tau, acc_bias_tau], dtype=float)
    inst = np.array([gyro_bias_instability, acc_bias_instability], dtype=float)
    if np.any(np.isnan(taus)) or np.any(taus <= 0):
        raise OptinavError(f"bias correlation times {taus.tolist()} must be > 0 s", "pass τ in s (inf = constant)")
    if np.any(inst < 0) or not np.all(np.isfinite(inst)):
        raise OptinavError("bias instability must be a finite number ≥ 0", "pass σ in rad/s (gyro) or m/s² (accel)")
    gm_decay = np.repeat(1.0 / taus, 3)  # 0 for τ = inf: a random constant
    gm_psd = np.repeat(2.0 * inst**2 / taus, 3)
    dt = np.diff(t)
    if q0 is None:
        span = t[-1] - t[0]
        q = coarse_alignment(dvv.sum(0) / span, dth.sum(0) / span, lat, h, frame, earth).q_b_n
    else:
        q = np.asarray(q0, dtype=float)
    w_ie = _earth.earth_rate(lat, frame, earth)
    g_n = _earth.gravity_vector(lat, h, frame, earth)
    # filter-step boundaries: group samples so each step spans about kf_interval seconds
    step_of = np.floor((t[1:] - t[0]) / kf_interval - 1e-9).astype(int)
    bounds = np.flatnonzero(np.diff(step_of)) + 1
    starts = np.concatenate([[0], bounds])
    ends = np.concatenate([bounds, [dth.shape[0]]])
    P = np.diag(
        np.concatenate(
            [
                np.square(initial_attitude_std),
                np.full(3, 0.1**2),
                np.full(3, gyro_bias_std**2),
                np.full(3, acc_bias_std**2),
            ]
        )
    )
    x_bias = np.zeros(6)  # fed-back bias estimates [ε (rad/s), ∇ (m/s²)]
    v = np.zeros(3)
    qn = np.diag(np.concatenate([np.full(3, gyro_white**2), np.full(3, acc_white**2)]))
    eye12, eye3 = np.eye(12), np.eye(3)
    q_gm = np.diag(gm_psd)
    hist_t, hist_q, hist_s = [], [], []
    # the Earth terms of the error model are constant on a static base: built once, the attitude blocks per step
    F, G = _error_model_static(lat, h, frame, earth)
    F[6:12, 6:12] -= np.diag(gm_decay)
    for a, b in zip(starts, ends):
        T = float(t[b] - t[a])
        d_th = dth[a:b] - x_bias[:3] * dt[a:b, None]
        d_v = dvv[a:b] - x_bias[3:] * dt[a:b, None]
        qs = attitude_update(q, d_th, omega_in_n=w_ie, dt=dt[a:b])
        # the step's attitudes are unit quaternions of the update: the closed forms of dcm_from_quat, np.cross and
        # quat_from_rotvec, bit for bit, without their checks and scipy objects (which were half of each step)
        c_all = _dcm_of_quats(qs)
        # velocity: rotate each increment at its start attitude (rotation/sculling terms vanish on a static base)
        v = v + np.einsum("kij,kj->i", c_all[:-1], d_v) + g_n * T - 2 * _cross(w_ie, v) * T
        q = qs[-1]
        _error_model_attitude(F, G, c_all[-1])
        Phi = eye12 + F * T + F @ F * (T * T / 2)
        Qd = G @ qn @ G.T * T
        Qd[6:12, 6:12] += q_gm * T
        P = Phi @ P @ Phi.T + Qd
        r_std = velocity_noise if velocity_noise is not None else max(acc_white * np.sqrt(T), 1e-6)
        # the measurement H = [0 I 0 0] picks the velocity states: H P Hᵀ, P Hᵀ and K H as slices
        S = P[3:6, 3:6] + eye3 * r_std**2
        K = P[:, 3:6] @ np.linalg.inv(S)
        x = K @ v  # measurement: computed velocity minus zero
        I_KH = eye12.copy()
        I_KH[:, 3:6] -= K
        P = I_KH @ P @ I_KH.T + K @ K.T * r_std**2  # Joseph form keeps P symmetric positive
        # feedback: C_true = (I + [φ×]) C_computed, δv removed, biases accumulated
        q = quat_multiply(_quat_of_rotvec(x[0:3]), q)
        v = v - x[3:6]
        x_bias = x_bias + x[6:12]
        hist_t.append(t[b])
        hist_q.append(q)
        hist_s.append(np.sqrt(np.diag(P)[0:3]))
    c = dcm_from_quat(q)
    sd = np.sqrt(np.diag(P))
    # biases were estimated in the body frame through C_b^n: ε, ∇ states are body-frame
    return AlignmentResult(
        "kalman",
        frame,
        q,
        euler_from_dcm(c, frame),
        sd[0:3],
        gyro_bias=x_bias[:3],
        gyro_bias_std=sd[6:9],
        acc_bias=x_bias[3:],
        acc_bias_std=sd[9:12],
        history_t=np.asarray(hist_t),
        history_euler=euler_from_dcm(dcm_from_quat(np.reshape(hist_q, (-1, 4))), frame),
        history_attitude_std=np.asarray(hist_s),
    )


def attitude_error(c_est, c_true) -> np.ndarray:
    """φ with ``C_est = (I − [φ×]) C_true`` to first order (exact rotation vector).

    Parameters
    ----------
    c_est, c_true : (..., 3, 3) array
        Estimated and true ``C_b^n`` [-].

    Returns
    -------
    (..., 3) ndarray
        φ in navigation axes [rad].
    """
    return -rotvec_from_dcm(np.asarray(c_est) @ np.swapaxes(np.asarray(c_true), -1, -2))


__all__ = ["AlignmentResult", "alignment_limits", "attitude_error", "coarse_alignment", "fine_alignment"]
