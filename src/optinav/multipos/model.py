"""Accelerometer norm-observation model for multi-position calibration without a turntable.

Forward model of a triad (the convention of every optinav calibration result)::

    raw = K·a + b,     a = K⁻¹(raw − b)

``a`` is the true specific force in the sensor frame (m/s²), ``raw`` the output in the input units (counts,
m/s², g, …), ``b`` the bias in raw units and ``K`` the scale/misalignment matrix in raw units per m/s². At
rest ``‖a‖ = g`` whatever the attitude, so each static pose k with mean output m_k gives the observation
(Lötters et al. 1998; Gao & Zhang 2019 eqs. 3–6)::

    r_k(θ) = ‖K⁻¹(m_k − b)‖ − g.

Norms carry no reference direction, so only K's upper triangle is identifiable (the sensor frame is defined
by the z axis and the y–z plane of the sensitive axes): θ = [K_xx, K_yy, K_zz, K_xy, K_xz, K_yz, b_x, b_y,
b_z] (Gao & Zhang eq. 1 with S_ii = K_ii·g and E_ij = S_ii·M_ij). With ``‖u‖`` and ``w = K⁻ᵀu/‖u‖`` the
analytic Jacobian is ``∂r/∂b = −w`` and ``∂r/∂K_ij = −w_i·u_j``.
"""

from __future__ import annotations

import numpy as np

from optinav.core.validate import as_float_array
from optinav.errors import OptinavError

#: parameter names of the 9-parameter (upper-triangular) accelerometer model, in θ order
ACCEL_PARAMS = ("K_xx", "K_yy", "K_zz", "K_xy", "K_xz", "K_yz", "b_x", "b_y", "b_z")
#: the (row, column) of K for θ[0:6]
K_INDEX = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))


def theta_to_Kb(theta) -> tuple[np.ndarray, np.ndarray]:
    """θ (..., 9) → K (..., 3, 3) upper triangular and b (..., 3)."""
    th = np.asarray(theta, dtype=float)
    K = np.zeros(th.shape[:-1] + (3, 3))
    for j, (r, c) in enumerate(K_INDEX):
        K[..., r, c] = th[..., j]
    return K, th[..., 6:9].copy()


def Kb_to_theta(K, b) -> np.ndarray:
    """K (3, 3) upper triangular and b (3,) → θ (9,). A K with a lower triangle is an error."""
    K = as_float_array(K, "K", last_dims=(3, 3))
    b = as_float_array(b, "b", last_dims=(3,))
    low = np.abs(np.tril(K, -1)).max()
    if low > 1e-12 * np.abs(K).max():
        raise OptinavError(
            "K has non-zero entries below the diagonal, which norm observations cannot determine",
            "express K in the upper-triangular form (sensor z axis and y–z plane as reference)",
        )
    return np.array([K[r, c] for r, c in K_INDEX] + list(b))


def _solve_upper(K: np.ndarray, v: np.ndarray) -> np.ndarray:
    """K⁻¹v for upper-triangular K (..., 3, 3) and v (..., P, 3), by back substitution (vectorized)."""
    k = K[..., None, :, :]
    u2 = v[..., 2] / k[..., 2, 2]
    u1 = (v[..., 1] - k[..., 1, 2] * u2) / k[..., 1, 1]
    u0 = (v[..., 0] - k[..., 0, 1] * u1 - k[..., 0, 2] * u2) / k[..., 0, 0]
    return np.stack([u0, u1, u2], axis=-1)


def corrected(theta, raw) -> np.ndarray:
    """a = K⁻¹(raw − b) for θ (9,) or (M, 9) and raw (P, 3) → (P, 3) or (M, P, 3)."""
    K, b = theta_to_Kb(theta)
    raw = np.asarray(raw, dtype=float)
    return _solve_upper(K, raw - b[..., None, :])


def norm_residuals(theta, means, g: float) -> np.ndarray:
    """r_k = ‖K⁻¹(m_k − b)‖ − g (m/s²) for θ (9,) → (P,) or a population θ (M, 9) → (M, P), means (P, 3)."""
    from optinav.multipos._kernels import norm_residuals_kernel  # numba: loaded on first use

    th = np.asarray(theta, dtype=float)
    pts = np.asarray(means, dtype=float)
    r = norm_residuals_kernel(np.ascontiguousarray(th.reshape(-1, 9)), np.ascontiguousarray(pts.T), float(g))
    return r.reshape(th.shape[:-1] + (pts.shape[0],))


def norm_jacobian(theta, means) -> np.ndarray:
    """∂r/∂θ (P, 9) of :func:`norm_residuals` (analytic, see the module docstring)."""
    th = np.asarray(theta, dtype=float)
    K, _ = theta_to_Kb(th)
    u = corrected(th, means)
    un = u / np.linalg.norm(u, axis=-1, keepdims=True)
    w = np.linalg.solve(K.T, un.T).T  # w_k = K⁻ᵀ û_k
    J = np.empty((u.shape[0], 9))
    for j, (r, c) in enumerate(K_INDEX):
        J[:, j] = -w[:, r] * u[:, c]
    J[:, 6:9] = -w
    return J


def norm_hessian(theta, means, g: float) -> np.ndarray:
    """Exact Hessian (9, 9) of E(θ) = Σ r_k² by central differences of the analytic gradient 2Jᵀr.

    Newton's method on E (Frosio et al. 2009) needs second derivatives; differencing the analytic
    gradient is accurate to ~1e-8 relative, ample for a Newton step.
    """
    th = np.asarray(theta, dtype=float)
    H = np.empty((9, 9))
    h = 1e-6 * np.maximum(np.abs(th), np.abs(th[:3]).mean())
    for j in range(9):
        e = np.zeros(9)
        e[j] = h[j]
        gp = 2 * norm_jacobian(th + e, means).T @ norm_residuals(th + e, means, g)
        gm = 2 * norm_jacobian(th - e, means).T @ norm_residuals(th - e, means, g)
        H[:, j] = (gp - gm) / (2 * h[j])
    return 0.5 * (H + H.T)


def gravity_excitation(acc) -> np.ndarray:
    """The linear observation block H_k = [I₃, G_k] (3, 9) of one pose (Gao & Zhang eq. 13).

    ``acc``: specific force in the sensor frame (m/s²). Columns in the order [B_x, B_y, B_z, S_xx, S_yy, S_zz,
    E_xy, E_xz, E_yz] of the paper's linear output model N = K·f + B with K upper triangular.
    """
    fx, fy, fz = as_float_array(acc, "acc", last_dims=(3,))
    G = np.array([[fx, 0, 0, fy, fz, 0], [0, fy, 0, 0, 0, fz], [0, 0, fz, 0, 0, 0]], dtype=float)
    return np.hstack([np.eye(3), G])


def to_paper(K, b, g: float) -> dict:
    """Our K (raw per m/s²), b → the paper's S_ii (output per 1 g input), M_ij (rad) and B (raw units)."""
    K = as_float_array(K, "K", last_dims=(3, 3))
    S = np.diag(K) * g
    return {
        "S": S,
        "M_xy": K[0, 1] / K[0, 0],
        "M_xz": K[0, 2] / K[0, 0],
        "M_yz": K[1, 2] / K[1, 1],
        "B": as_float_array(b, "b", last_dims=(3,)).copy(),
    }


def from_paper(S, M_xy: float, M_xz: float, M_yz: float, B, g: float) -> tuple[np.ndarray, np.ndarray]:
    """The paper's parameters (S per 1 g, misalignments rad, bias) → our upper-triangular K and b."""
    S = as_float_array(S, "S", last_dims=(3,)) / g
    K = np.array([[S[0], S[0] * M_xy, S[0] * M_xz], [0.0, S[1], S[1] * M_yz], [0.0, 0.0, S[2]]])
    return K, as_float_array(B, "B", last_dims=(3,)).copy()


def upper_triangular_form(K) -> tuple[np.ndarray, np.ndarray]:
    """K = U·Q with U upper triangular (positive diagonal) and Q a rotation: the part of a full K that norm
    observations determine (U) and the frame rotation they cannot see (Q). A gyroscope calibrated against
    this accelerometer's gravity directions comes out as K_g·Qᵀ (its axes expressed in the same frame)."""
    from scipy.linalg import rq

    K = as_float_array(K, "K", last_dims=(3, 3))
    U, Q = rq(K)
    s = np.sign(np.diag(U))
    s[s == 0] = 1.0
    U, Q = U * s[None, :], s[:, None] * Q
    if np.linalg.det(Q) < 0:
        raise OptinavError("K has a negative determinant (a left-handed triad)", "check the axis signs")
    return U, Q
