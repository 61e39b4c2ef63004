"""Gimbal chain of a dual-axis rotational INS with non-orthogonality errors (Li et al. 2023, eqs. 1–6, 12–14).

Frames (paper §1.1): n = East-North-Up; b = vehicle right-front-up; s = IMU (orthogonal, on the sensitive
axes), fixed to the inner gimbal; h1 = inner frame (z_h1 on the inner axis, turns by α); h0 = inner-zero frame
(h1 at α = 0, fixed to the outer gimbal); h2 = outer frame (y_h2 on the outer axis, turns by β, h2 = b at β = 0).
These are exactly optinav's ``"enu"`` convention (docs/conventions.md: n ENU, b right-forward-up, Euler
``C_b^n = R_z(yaw) R_x(pitch) R_y(roll)``).

Chain (eq. 6)::

    C_b^n = C_s^n · C_h1^s(θ) · C_h0^h1(α) · C_h2^h0(η) · C_b^h2(β)

with ``C_h0^h1(α) = R_z(α)ᵀ`` (eq. 1 transposed), ``C_b^h2(β) = R_y(β)ᵀ`` (eq. 2, ``R_y`` the active rotation
:func:`optinav.core.rotations.rot_y`). The non-orthogonality matrices are exact rotations (eq. 3)::

    C_h1^s(θ) = (C_s^h1)ᵀ = R_z(θz) R_x(θx) R_y(θy),      C_h2^h0(η) = R_z(ηz) R_x(ηx) R_y(ηy)

whose first-order forms are ``I + [θ×]`` and ``I + [η×]`` (eqs. 4, 5: ``C_s^h1 = I − [θ×]``);
``small_angle=True`` uses those linear forms instead (as the paper's particles, eqs. 10–11).

Residual (eqs. 12–14): the attitude change of the extracted vehicle attitude relative to the first epoch,
``E_t = C̃_{b,0}^nᵀ C̃_{b,t}^n``, as Euler angles ``[roll, pitch, yaw]`` (ENU convention; the paper and PSINS's
``m2att`` list them as [pitch, roll, yaw]) per epoch.
On a static base the true ``E_t`` is the identity, so the paper's fitness is ``F = sqrt(Σ_t |e_t|² / T)``.

Parameter vector ``p = [θx, θy, θz, ηx, ηy, ηz]`` (rad); every function takes ``p`` as (6,) or a batch (P, 6).
"""

from __future__ import annotations

import numba
import numpy as np

from optinav.core.rotations import rot_x, rot_y, rot_z, small_angle_dcm
from optinav.errors import OptinavError

__all__ = [
    "PARAM_NAMES",
    "nonorth_dcm",
    "chain_pieces",
    "vehicle_attitude",
    "attitude_change",
    "euler_rpy",
    "residuals",
    "residual_jacobian",
    "sensor_attitude",
    "equivalent_angles",
]

#: parameter names in the order of ``p``
PARAM_NAMES = ("theta_x", "theta_y", "theta_z", "eta_x", "eta_y", "eta_z")


#: epochs per chunk of :func:`residuals` and :func:`residual_jacobian`: their temporaries (about 1 kB per epoch
#: and parameter vector) stay bounded while only the result grows with the recording
CHUNK_EPOCHS = 1 << 14


def _pieces(alpha, beta, pieces, a: int, b: int):
    """The gimbal rotations (Z, Y) of epochs a..b−1: of ``pieces`` when given, else computed for those epochs only
    (a long recording's (T, 3, 3) pair is not held)."""
    if pieces is not None:
        return pieces[0][a:b], pieces[1][a:b]
    return chain_pieces(np.asarray(alpha, float)[a:b], np.asarray(beta, float)[a:b])


def _params(p) -> tuple[np.ndarray, bool]:
    p = np.asarray(p, dtype=float)
    single = p.ndim == 1
    p2 = np.atleast_2d(p)
    if p2.ndim != 2 or p2.shape[1] != 6:
        raise OptinavError(
            f"non-orthogonality parameters have shape {p.shape}, expected (6,) or (P, 6)",
            "pass [theta_x, theta_y, theta_z, eta_x, eta_y, eta_z] in rad",
        )
    return p2, single


def nonorth_dcm(angles, small_angle: bool = False) -> np.ndarray:
    """``R_z(a_z) R_x(a_x) R_y(a_y)`` (exact, eq. 3 transposed) or ``I + [a×]`` (eqs. 4–5 transposed).

    angles: (..., 3) [a_x, a_y, a_z] in rad. Gives ``C_h1^s`` for θ and ``C_h2^h0`` for η.
    """
    a = np.asarray(angles, dtype=float)
    if small_angle:
        return small_angle_dcm(a)
    return rot_z(a[..., 2]) @ rot_x(a[..., 0]) @ rot_y(a[..., 1])


def _zxy(c) -> np.ndarray:
    """``[a_x, a_y, a_z]`` (rad) of ``c = R_z(a_z) R_x(a_x) R_y(a_y)`` (the inverse of :func:`nonorth_dcm`)."""
    roll, pitch, yaw = euler_rpy(c)
    return np.array([pitch, roll, yaw])


def equivalent_angles(p, split: float = 0.0, eta_y: float = 0.0) -> np.ndarray:
    """The angles ``p'`` that give exactly the vehicle attitudes of ``p`` (eq. 6) with ``θz' − ηz' = split`` and
    ``ηy' = eta_y`` [rad].

    The chain holds ``C_h1^s Z(α) C_h2^h0 Y(β)``; ``R_z(d)`` commutes with ``Z(α)`` and ``R_y(e)`` with ``Y(β)``, so
    ``C_h1^s → C_h1^s R_z(d)``, ``C_h2^h0 → R_z(−d) C_h2^h0 R_y(e)`` leave every ``E_t`` (eqs. 12–14) unchanged
    (``e`` turns the vehicle frame about the outer axis: ``E_t → R_y(e)ᵀ E_t R_y(e)``, the identity stays the
    identity). In the angles of eq. 3 this is ``ηz − d``, ``ηy + e`` exactly, but ``θz + d`` only to first order:
    ``(θx, θy)`` turn about z by ``−d`` (``θx' ≈ θx + d·θy``, ``θy' ≈ θy − d·θx``). The split of ``θz − ηz`` is
    not observable, so neither are θx, θy beyond first order; a calibration reports them at ``split = 0``,
    ``ηy = 0`` (docs/methods/rins.md, "Observability").

    Parameters
    ----------
    p : (6,) array
        ``[θx, θy, θz, ηx, ηy, ηz]`` [rad].
    split : float
        ``θz' − ηz'`` wanted [rad].
    eta_y : float
        ``ηy'`` wanted [rad].

    Returns
    -------
    (6,) ndarray
        ``[θx', θy', θz', ηx, ηy', ηz']`` [rad].
    """
    p = np.asarray(p, float)
    A, B = nonorth_dcm(p[0:3]), nonorth_dcm(p[3:6])
    d = 0.5 * (p[5] - p[2] + split)  # exact to first order; θz'(d) = θz + d + O(θx·θy·d)
    for _ in range(50):  # f(d) = θz'(d) − (ηz − d) − split has slope 2 + O(θ²): converges in a few steps
        f = _zxy(A @ rot_z(d))[2] - (p[5] - d) - split
        d -= 0.5 * f
        if abs(f) < 1e-15:
            break
    th = _zxy(A @ rot_z(d))
    et = _zxy(rot_z(-d) @ B)
    return np.array([th[0], th[1], th[2], et[0], eta_y, et[2]])


def chain_pieces(alpha, beta):
    """``Z_t = C_h0^h1(α_t) = R_z(α)ᵀ`` and ``Y_t = C_b^h2(β_t) = R_y(β)ᵀ``, each (T, 3, 3)."""
    return np.swapaxes(rot_z(np.asarray(alpha, float)), -1, -2), np.swapaxes(rot_y(np.asarray(beta, float)), -1, -2)


def vehicle_attitude(c_s_n, alpha, beta, p, small_angle: bool = False, pieces=None) -> np.ndarray:
    """Eq. 6: the vehicle attitude ``C_b^n`` through the gimbal chain (Li et al. 2023).

    Parameters
    ----------
    c_s_n : (T, 3, 3) array
        IMU attitude ``C_s^n`` at the epochs [-].
    alpha, beta : (T,) array
        Inner / outer encoder angles [rad].
    p : (6,) or (P, 6) array
        Non-orthogonality angles ``[θx, θy, θz, ηx, ηy, ηz]`` [rad], one vector or a batch.
    small_angle : bool
        The first-order matrices ``I + [θ×]`` (eqs. 4, 5) instead of exact rotations.
    pieces : tuple or None
        Precomputed :func:`chain_pieces` (Z, Y) of these angles (saves their cost per call).

    Returns
    -------
    (T, 3, 3) or (P, T, 3, 3) ndarray
        ``C_b^n`` [-] (ENU navigation frame, right-front-up body).
    """
    p2, single = _params(p)
    Z, Y = chain_pieces(alpha, beta) if pieces is None else pieces
    A = nonorth_dcm(p2[:, 0:3], small_angle)  # (P,3,3)
    B = nonorth_dcm(p2[:, 3:6], small_angle)
    c = np.ascontiguousarray(c_s_n, dtype=float)
    out = _chain(
        c,
        np.ascontiguousarray(A),
        np.ascontiguousarray(Z, dtype=float),
        np.ascontiguousarray(B),
        np.ascontiguousarray(Y, dtype=float),
    )
    return out[0] if single else out


@numba.njit(cache=True, nogil=True)
def _chain(c, A, Z, B, Y):
    """``c_t A_p Z_t B_p Y_t`` for every particle p and epoch t, (P, T, 3, 3): the products of NumPy's stacked
    matmul (left to right, each element summed over k in order) in one pass, without the (P, T) temporaries
    that made the fits' cost."""
    P, T = A.shape[0], c.shape[0]
    out = np.empty((P, T, 3, 3))
    m1 = np.empty((3, 3))
    m2 = np.empty((3, 3))
    for p in range(P):
        for t in range(T):
            _mm(c[t], A[p], m1)
            _mm(m1, Z[t], m2)
            _mm(m2, B[p], m1)
            _mm(m1, Y[t], out[p, t])
    return out


@numba.njit(cache=True, nogil=True)
def _change_euler(C, C0, out):
    """:func:`euler_rpy` of :func:`attitude_change` into ``out`` (P, T, 3) for the epochs ``C`` (P, T, 3, 3) relative
    to ``C0`` (P, 3, 3), from the five elements of ``E_t = C_0ᵀ C_t`` it needs."""
    P, T = C.shape[0], C.shape[1]
    for p in range(P):
        c0 = C0[p]
        for t in range(T):
            ct = C[p, t]
            e = np.empty((3, 3))
            for i in (0, 1, 2):
                for j in (0, 1, 2):
                    e[i, j] = c0[0, i] * ct[0, j] + c0[1, i] * ct[1, j] + c0[2, i] * ct[2, j]
            out[p, t, 0] = np.arctan2(-e[2, 0], e[2, 2])
            out[p, t, 1] = np.arcsin(min(max(e[2, 1], -1.0), 1.0))
            out[p, t, 2] = np.arctan2(-e[0, 1], e[1, 1])


@numba.njit(cache=True, nogil=True, inline="always")
def _mm(a, b, out):
    for i in range(3):
        for j in range(3):
            s = a[i, 0] * b[0, j]
            s += a[i, 1] * b[1, j]
            s += a[i, 2] * b[2, j]
            out[i, j] = s


def sensor_attitude(C_b_n, alpha, beta, p, small_angle: bool = False) -> np.ndarray:
    """Inverse of eq. 6: ``C_s^n = C_b^n C_h2^b(β) C_h0^h2 C_h1^h0(α) C_s^h1`` (T, 3, 3) for one ``p`` (6,)."""
    p = np.asarray(p, float)
    Z, Y = chain_pieces(alpha, beta)
    A = nonorth_dcm(p[0:3], small_angle)
    B = nonorth_dcm(p[3:6], small_angle)
    tr = lambda m: np.swapaxes(m, -1, -2)  # noqa: E731
    return np.asarray(C_b_n, float) @ tr(Y) @ B.T @ tr(Z) @ A.T


def euler_rpy(c) -> np.ndarray:
    """``[roll, pitch, yaw]`` (rad) of ``C = R_z(yaw) R_x(pitch) R_y(roll)`` (ENU convention): the closed form of
    ``rotations.euler_from_dcm(c, "enu")``, kept here because the fits evaluate it for every particle and epoch."""
    c = np.asarray(c, float)
    pitch = np.arcsin(np.clip(c[..., 2, 1], -1.0, 1.0))
    roll = np.arctan2(-c[..., 2, 0], c[..., 2, 2])
    yaw = np.arctan2(-c[..., 0, 1], c[..., 1, 1])
    return np.stack([roll, pitch, yaw], axis=-1)


def attitude_change(C_b_n) -> np.ndarray:
    """``E_t = C_{b,0}^nᵀ C_{b,t}^n`` for (..., T, 3, 3) attitudes (eqs. 12–14, relative to the first epoch)."""
    c = np.asarray(C_b_n, float)
    return np.swapaxes(c[..., :1, :, :], -1, -2) @ c


def residuals(c_s_n, alpha, beta, p, small_angle: bool = False, pieces=None) -> np.ndarray:
    """Eqs. 12–14: Euler angles [roll, pitch, yaw] of ``E_t = C_{b,0}^nᵀ C_{b,t}^n`` for t ≥ 1.

    Parameters
    ----------
    c_s_n : (T, 3, 3) array
        IMU attitude ``C_s^n`` at the epochs [-].
    alpha, beta : (T,) array
        Inner / outer encoder angles [rad].
    p : (6,) or (P, 6) array
        Non-orthogonality angles ``[θx, θy, θz, ηx, ηy, ηz]`` [rad], one vector or a batch.
    small_angle : bool
        The first-order matrices of eqs. 4, 5 (the paper's particles) instead of exact rotations.
    pieces : tuple or None
        Precomputed :func:`chain_pieces` (Z, Y).

    Returns
    -------
    (3(T−1),) or (P, 3(T−1)) ndarray
        The residuals, epoch-major [rad] (ENU Euler convention).
    """
    p2, single = _params(p)
    T = len(c_s_n)
    e = np.empty((p2.shape[0], max(T - 1, 0), 3))
    c0 = vehicle_attitude(c_s_n[:1], alpha[:1], beta[:1], p2, small_angle, _pieces(alpha, beta, pieces, 0, 1))[:, 0]
    for a in range(1, T, CHUNK_EPOCHS):  # the chain's (P, chunk, 3, 3) temporaries, not (P, T, 3, 3)
        b = min(a + CHUNK_EPOCHS, T)
        C = vehicle_attitude(c_s_n[a:b], alpha[a:b], beta[a:b], p2, small_angle, _pieces(alpha, beta, pieces, a, b))
        _change_euler(C, c0, e[:, a - 1 : b - 1])
    e = e.reshape(p2.shape[0], -1)
    return e[0] if single else e


def _param_axes(a: np.ndarray) -> np.ndarray:
    """Right-perturbation axes: ``∂(R_z R_x R_y)/∂a_k = (R_z R_x R_y)[w_k×]``; rows w_x, w_y, w_z (3, 3)."""
    ry = rot_y(a[1])
    rxy = rot_x(a[0]) @ ry
    m = rot_z(a[2]) @ rxy
    return np.stack([ry.T @ np.array([1.0, 0, 0]), np.array([0.0, 1, 0]), m.T @ np.array([0.0, 0, 1])])


def residual_jacobian(c_s_n, alpha, beta, p, pieces=None) -> np.ndarray:
    """Analytic ∂r/∂p of :func:`residuals` for the exact chain.

    A change of θ_k turns ``C̃_t`` on the right by ``v_t = (Z_t B Y_t)ᵀ w_k`` (η_k: ``v_t = Y_tᵀ u_k``), so
    ``E_t`` turns on the right by ``d_t = v_t − E_tᵀ v_0``; the Euler rates follow from the body rate by
    ``ω = [e_y, R_y(γ)ᵀe_x, R_y(γ)ᵀR_x(θ)ᵀe_z]·[γ̇, θ̇, ψ̇]`` (ENU Euler kinematics).

    Parameters
    ----------
    c_s_n : (T, 3, 3) array
        IMU attitude ``C_s^n`` at the epochs [-].
    alpha, beta : (T,) array
        Inner / outer encoder angles [rad].
    p : (6,) array
        Non-orthogonality angles ``[θx, θy, θz, ηx, ηy, ηz]`` [rad].
    pieces : tuple or None
        Precomputed :func:`chain_pieces` (Z, Y).

    Returns
    -------
    (3(T−1), 6) ndarray
        The Jacobian [rad/rad].
    """
    p = np.asarray(p, float)
    A = nonorth_dcm(p[0:3])
    B = nonorth_dcm(p[3:6])
    W = _param_axes(p[0:3])  # (3,3) rows
    U = _param_axes(p[3:6])
    c_s_n = np.asarray(c_s_n, float)

    def chain(a, b):
        """c_t = C_s^n A Z B Y and the rows (ZBY)ᵀw_k, Yᵀu_k (k, 6, 3) of epochs a..b−1."""
        Z, Y = _pieces(alpha, beta, pieces, a, b)
        ZBY = Z @ B @ Y
        return (c_s_n[a:b] @ A) @ ZBY, np.concatenate([W @ ZBY, U @ Y], axis=1)

    c0, v0 = (x[0] for x in chain(0, 1))
    T = len(c_s_n)
    out = np.empty((max(T - 1, 0), 3, 6))
    for a in range(1, T, CHUNK_EPOCHS):  # temporaries of a chunk of epochs (about 1 kB each), not of all
        b = min(a + CHUNK_EPOCHS, T)
        c, v = chain(a, b)
        E = c0.T @ c
        d = v - v0 @ E  # rows E_tᵀ v_0
        eul = euler_rpy(E)
        roll, pitch = eul[:, 0], eul[:, 1]
        cr, sr, cp, sp = (x[:, None] for x in (np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch)))
        wx, wy, wz = d[..., 0], d[..., 1], d[..., 2]
        pitch_rate = cr * wx + sr * wz
        yaw_rate = (cr * wz - sr * wx) / cp
        out[a - 1 : b - 1, 0] = wy - yaw_rate * sp  # roll rate
        out[a - 1 : b - 1, 1] = pitch_rate
        out[a - 1 : b - 1, 2] = yaw_rate
    return out.reshape(-1, 6)
