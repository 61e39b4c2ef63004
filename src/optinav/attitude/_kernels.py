"""numba kernels of the attitude estimators (private; the numpy API is in :mod:`optinav.attitude.estimators`) and
of the input checks' gravity drift (:func:`gravity_means`, used by :mod:`optinav.attitude.checks`).

Quaternion products, rotation-vector exponentials and normalization are the kernels of :mod:`optinav.core._quat`,
shared with the strapdown. One measurement model (:func:`_model`) is shared by every estimator and by the public
numpy functions of :mod:`optinav.attitude.measurement`. Per-sample loops allocate their small work arrays once, so the batch
kernels run at ~1 µs per sample or less. Every loop kernel takes a ``state`` array that it reads at the
start and writes back at the end: the streaming classes call the same kernel with one sample.

Arrays are copied element by element, never by slice assignment (``a[0:4] = b``): numba compiles that one's
shape-mismatch message (string formatting) on first use, 2.4 s of a cold process's first gd/cg/qn/mekf call.

Quaternions ``[w, x, y, z]``, ``q`` = q_b^n. Error-angle parameterizations (``mode``):
0 = body frame (right perturbation, ``q ⊗ exp(δθ/2)``), 1 = navigation frame (left, ``exp(φ/2) ⊗ q``),
2 = quaternion tangent (4 columns, ``d/dq`` of the model on the unit sphere).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from optinav.core._quat import qmul, qnormalize, qrotate, qupdate, rv2q

_NJ = dict(cache=True, nogil=True, fastmath=False)

#: counts vector layout written by the loop kernels
C_POL_USED, C_POL_NEAR_ZENITH, C_ACC_SHRUNK = 0, 1, 2

#: the modes of :func:`_model` as int64 values, not int constants: numba types a constant argument as a literal and
#: compiled the model once per caller's mode (gd/cg, qn, mekf and measurement_error's variable: four times, ~1 s
#: each on a cold cache)
MODE_BODY, MODE_NAV, MODE_QUAT = np.int64(0), np.int64(1), np.int64(2)


@numba.njit(**_NJ)
def _dcm(q, C):
    """C_b^n of a unit quaternion into C (3x3)."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    C[0, 0] = w * w + x * x - y * y - z * z
    C[0, 1] = 2.0 * (x * y - w * z)
    C[0, 2] = 2.0 * (x * z + w * y)
    C[1, 0] = 2.0 * (x * y + w * z)
    C[1, 1] = w * w - x * x + y * y - z * z
    C[1, 2] = 2.0 * (y * z - w * x)
    C[2, 0] = 2.0 * (x * z - w * y)
    C[2, 1] = 2.0 * (y * z + w * x)
    C[2, 2] = w * w - x * x - y * y + z * z


@numba.njit(**_NJ)
def _normalize(q):
    q[0], q[1], q[2], q[3] = qnormalize(q[0], q[1], q[2], q[3])


@numba.njit(**_NJ)
def _rotvec_quat(vx, vy, vz, out):
    """Exact quaternion of the rotation vector v (rad), into ``out``."""
    out[0], out[1], out[2], out[3] = rv2q(vx, vy, vz)


@numba.njit(**_NJ)
def _qmul_into(p, r, out):
    """out = p ⊗ r (out must not alias p or r)."""
    out[0], out[1], out[2], out[3] = qmul(p[0], p[1], p[2], p[3], r[0], r[1], r[2], r[3])


@numba.njit(**_NJ)
def _copy(dst, src):
    """dst[:] = src, element by element (module docstring). A function of its own: the same loops written out at
    the end of run_gd_cg made its per-sample loop 8 % slower (LLVM optimized it otherwise)."""
    for i in range(src.shape[0]):
        dst[i] = src[i]


@numba.njit(**_NJ)
def _right_rotate(q, vx, vy, vz, dq, tmp):
    """q ← q ⊗ exp(v/2) (body-frame rotation vector v)."""
    _rotvec_quat(vx, vy, vz, dq)
    _qmul_into(q, dq, tmp)
    q[0], q[1], q[2], q[3] = tmp[0], tmp[1], tmp[2], tmp[3]
    _normalize(q)


@numba.njit(**_NJ)
def _left_rotate(q, vx, vy, vz, dq, tmp):
    """q ← exp(v/2) ⊗ q (navigation-frame rotation vector v)."""
    _rotvec_quat(vx, vy, vz, dq)
    _qmul_into(dq, q, tmp)
    q[0], q[1], q[2], q[3] = tmp[0], tmp[1], tmp[2], tmp[3]
    _normalize(q)


@numba.njit(**_NJ)
def _model(q, ah, un, use_pol, sn, Cbm, c2m, s2m, wpol, min_d2, mode, F, J, C, vb, sb):
    """The shared measurement model at one sample.

    ah: unit specific force (body); un: unit "up" (reaction to gravity) in n; sn: unit sun vector in n;
    Cbm: C_b^m; (c2m, s2m) = (cos 2α, sin 2α) of the measured AoP α; wpol: weight of the polarization rows.
    Writes F[0:3] = C_n^b u_n − â (gravity error), F[3:5] = wpol·([cos 2α′, sin 2α′] − [cos 2α, sin 2α])
    with α′ the predicted AoP, and the Jacobian J (5 × 3, or 5 × 4 for mode 2). Returns the number of rows
    used: 3 (gravity only), 5 (with polarization), or −3 when polarization was requested but the sun lies
    within the minimum angle of the sensor's viewing axis (``s_m,x² + s_m,y² < min_d2``).
    """
    _dcm(q, C)
    for i in range(3):
        vb[i] = C[0, i] * un[0] + C[1, i] * un[1] + C[2, i] * un[2]
        sb[i] = C[0, i] * sn[0] + C[1, i] * sn[1] + C[2, i] * sn[2]
    for i in range(3):
        F[i] = vb[i] - ah[i]
    # body-frame Jacobian of C_n^b v_n is [v_b×]
    J[0, 0] = 0.0
    J[0, 1] = -vb[2]
    J[0, 2] = vb[1]
    J[1, 0] = vb[2]
    J[1, 1] = 0.0
    J[1, 2] = -vb[0]
    J[2, 0] = -vb[1]
    J[2, 1] = vb[0]
    J[2, 2] = 0.0
    rows = 3
    if use_pol:
        x = Cbm[0, 0] * sb[0] + Cbm[0, 1] * sb[1] + Cbm[0, 2] * sb[2]
        y = Cbm[1, 0] * sb[0] + Cbm[1, 1] * sb[1] + Cbm[1, 2] * sb[2]
        d = x * x + y * y
        if d < min_d2:
            rows = -3
        else:
            # E′ ∝ s_m × z_m = [y, −x, 0]; doubled angle 2α′: cos = (y² − x²)/d, sin = −2xy/d (axial-safe)
            F[3] = wpol * ((y * y - x * x) / d - c2m)
            F[4] = wpol * (-2.0 * x * y / d - s2m)
            d2 = d * d
            dcx = -4.0 * x * y * y / d2
            dcy = 4.0 * x * x * y / d2
            dsx = -2.0 * y * (y * y - x * x) / d2
            dsy = -2.0 * x * (x * x - y * y) / d2
            # ∂F_p/∂s_b (2x3) = wpol·D·C_b^m[0:2]; then × [s_b×]
            for r in range(2):
                if r == 0:
                    ax_, ay_ = dcx, dcy
                else:
                    ax_, ay_ = dsx, dsy
                g0 = wpol * (ax_ * Cbm[0, 0] + ay_ * Cbm[1, 0])
                g1 = wpol * (ax_ * Cbm[0, 1] + ay_ * Cbm[1, 1])
                g2 = wpol * (ax_ * Cbm[0, 2] + ay_ * Cbm[1, 2])
                # row · [s_b×]
                J[3 + r, 0] = g1 * sb[2] - g2 * sb[1]
                J[3 + r, 1] = g2 * sb[0] - g0 * sb[2]
                J[3 + r, 2] = g0 * sb[1] - g1 * sb[0]
            rows = 5
    nr = rows if rows > 0 else 3
    if mode == 1:
        # φ_n → δθ_b = C_n^b φ_n: J_nav = J_body · C_n^b = J_body · Cᵀ
        for r in range(nr):
            a0, a1, a2 = J[r, 0], J[r, 1], J[r, 2]
            for k in range(3):
                J[r, k] = a0 * C[k, 0] + a1 * C[k, 1] + a2 * C[k, 2]
    elif mode == 2:
        # tangent quaternion Jacobian: δθ_b = 2 Ξ(q)ᵀ dq
        w, qx, qy, qz = q[0], q[1], q[2], q[3]
        for r in range(nr):
            a0, a1, a2 = J[r, 0], J[r, 1], J[r, 2]
            J[r, 0] = 2.0 * (-qx * a0 - qy * a1 - qz * a2)
            J[r, 1] = 2.0 * (w * a0 - qz * a1 + qy * a2)
            J[r, 2] = 2.0 * (qz * a0 + w * a1 - qx * a2)
            J[r, 3] = 2.0 * (-qy * a0 + qx * a1 + w * a2)
    return rows


@numba.njit(**_NJ)
def model_batch(q, acc, un, use_pol, sn, Cbm, aop, wpol, min_d2, mode, F, J, rows):
    """Vectorized :func:`_model` for the numpy API (sn may have 1 or N rows)."""
    n = q.shape[0]
    C = np.empty((3, 3))
    vb = np.empty(3)
    sb = np.empty(3)
    ah = np.empty(3)
    Jw = np.zeros((5, 4))
    Fw = np.zeros(5)
    for i in range(n):
        na = math.sqrt(acc[i, 0] ** 2 + acc[i, 1] ** 2 + acc[i, 2] ** 2)
        for k in range(3):
            ah[k] = acc[i, k] / na
        j = i if sn.shape[0] > 1 else 0
        r = _model(
            q[i],
            ah,
            un,
            use_pol[i],
            sn[j],
            Cbm,
            math.cos(2 * aop[i]),
            math.sin(2 * aop[i]),
            wpol,
            min_d2,
            mode,
            Fw,
            Jw,
            C,
            vb,
            sb,
        )
        rows[i] = r
        nr = r if r > 0 else 3
        for a in range(nr):
            F[i, a] = Fw[a]
            for b in range(J.shape[2]):
                J[i, a, b] = Jw[a, b]


@numba.njit(**_NJ)
def _prepare(i, acc, dt, ah):
    """Per-sample: step h and ‖a‖; ``ah`` ← the unit accelerometer direction (left as it was when ‖a‖ = 0)."""
    h = dt[i] if dt.shape[0] > 1 else dt[0]
    na = math.sqrt(acc[i, 0] ** 2 + acc[i, 1] ** 2 + acc[i, 2] ** 2)
    if na > 0.0:
        ah[0] = acc[i, 0] / na
        ah[1] = acc[i, 1] / na
        ah[2] = acc[i, 2] / na
    return h, na


# --- gradient descent (Madgwick) and conjugate gradient: quaternion-space update ---------------------------


@numba.njit(**_NJ)
def run_gd_cg(gyr, acc, dt, un, use_pol, sn, Cbm, c2, s2, wpol, min_d2, gain, conj, restart, state, out, counts):
    """Madgwick-style filter: q ← normalize(q + (½ q⊗ω − β·P/‖P‖)·dt).

    P = ∇F = Jᵀ F (gradient descent), or for ``conj`` the Polak–Ribière+ conjugate direction
    P_k = ∇F_k + β_k P_{k−1} (hybrid β_k = max(0, min(PR, FR)), PR = ∇F_kᵀ(∇F_k − ∇F_{k−1})/‖∇F_{k−1}‖²,
    FR = ‖∇F_k‖²/‖∇F_{k−1}‖²; restart every ``restart`` samples), bounded by β_k ≤ 1: when the gradient grows
    (FR > 1) an unbounded β amplifies the previous direction sample after sample, and with it rounding, so that
    the same motion in ENU and NED axes gave attitudes up to 0.3° apart.
    state = [q(4), previous gradient(4), previous direction(4), iteration count(1)].
    """
    n = gyr.shape[0]
    q = state[0:4].copy()
    gp = state[4:8].copy()
    dp = state[8:12].copy()
    it = int(state[12])
    C = np.empty((3, 3))
    vb = np.empty(3)
    sb = np.empty(3)
    ah = np.empty(3)
    F = np.zeros(5)
    J = np.zeros((5, 4))
    g = np.empty(4)
    qd = np.empty(4)
    for i in range(n):
        h, na = _prepare(i, acc, dt, ah)
        wx, wy, wz = gyr[i, 0], gyr[i, 1], gyr[i, 2]
        qd[0] = 0.5 * (-q[1] * wx - q[2] * wy - q[3] * wz)
        qd[1] = 0.5 * (q[0] * wx + q[2] * wz - q[3] * wy)
        qd[2] = 0.5 * (q[0] * wy - q[1] * wz + q[3] * wx)
        qd[3] = 0.5 * (q[0] * wz + q[1] * wy - q[2] * wx)
        if na > 0.0:
            j = i if sn.shape[0] > 1 else 0
            rows = _model(q, ah, un, use_pol[i], sn[j], Cbm, c2[i], s2[i], wpol, min_d2, MODE_QUAT, F, J, C, vb, sb)
            if rows == 5:
                counts[C_POL_USED] += 1
            elif rows == -3:
                counts[C_POL_NEAR_ZENITH] += 1
            nr = 5 if rows == 5 else 3
            for k in range(4):
                acc_ = 0.0
                for r in range(nr):
                    acc_ += J[r, k] * F[r]
                g[k] = acc_
            if conj:
                beta = 0.0
                den = gp[0] * gp[0] + gp[1] * gp[1] + gp[2] * gp[2] + gp[3] * gp[3]
                if den > 0.0 and it % restart != 0:
                    num = 0.0
                    gg = 0.0
                    for k in range(4):
                        num += g[k] * (g[k] - gp[k])
                        gg += g[k] * g[k]
                    # hybrid PR–FR (Gilbert & Nocedal 1992): PR bounded by FR keeps the direction descent
                    beta = max(0.0, min(num / den, gg / den, 1.0))
                for k in range(4):
                    gp[k] = g[k]
                    g[k] = g[k] + beta * dp[k]
                # keep the direction on the tangent of the unit sphere at q
                pq = g[0] * q[0] + g[1] * q[1] + g[2] * q[2] + g[3] * q[3]
                for k in range(4):
                    g[k] -= pq * q[k]
                    dp[k] = g[k]
                it += 1
            ng = math.sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2] + g[3] * g[3])
            if ng > 0.0:
                for k in range(4):
                    qd[k] -= gain * g[k] / ng
        for k in range(4):
            q[k] += qd[k] * h
        _normalize(q)
        out[i, 0] = q[0]
        out[i, 1] = q[1]
        out[i, 2] = q[2]
        out[i, 3] = q[3]
    _copy(state[0:4], q)
    _copy(state[4:8], gp)
    _copy(state[8:12], dp)
    state[12] = it


# --- quasi-Newton (BFGS) with the dynamic step factor and the accelerometer state threshold ----------------


@numba.njit(**_NJ)
def _grad3(J, F, nr, g):
    for k in range(3):
        a = 0.0
        for r in range(nr):
            a += J[r, k] * F[r]
        g[k] = a


@numba.njit(**_NJ)
def run_qn(
    gyr,
    acc,
    dt,
    un,
    use_pol,
    sn,
    Cbm,
    c2,
    s2,
    wpol,
    min_d2,
    gain,
    rate_gain,
    max_step,
    g_ref,
    acc_threshold,
    acc_shrink,
    h_reset,
    state,
    out,
    counts,
):
    """One quasi-Newton iteration per sample after gyro propagation (Jin et al. 2021, §2.3).

    q⁻ = q ⊗ exp(ω·dt/2); g = J_nᵀ F at q⁻ (navigation-frame error angle); D = −H g with H = B⁻¹ the BFGS
    inverse-Hessian approximation; step λ = min(max_step, (gain + rate_gain·‖q̇‖)·dt) with ‖q̇‖ = ‖ω‖/2 the
    quaternion derivative norm (the dynamic step factor), shrunk by ``acc_shrink`` when
    |‖a‖ − g_ref| > acc_threshold (the state threshold); q = exp(λD/2) ⊗ q⁻. Then BFGS updates H with
    s = λD and y = g(q) − g(q⁻) of the same sample's objective (skipped unless sᵀy > 0). Without a usable
    polarization row the vertical component of D is removed (heading is unobservable, so the gyro keeps it).
    state = [q(4), H(9)].
    """
    n = gyr.shape[0]
    q = state[0:4].copy()
    H = state[4:13].copy().reshape(3, 3)
    C = np.empty((3, 3))
    vb = np.empty(3)
    sb = np.empty(3)
    ah = np.empty(3)
    F = np.zeros(5)
    J = np.zeros((5, 4))
    g = np.empty(3)
    g2 = np.empty(3)
    d = np.empty(3)
    y = np.empty(3)
    Hy = np.empty(3)
    dq = np.empty(4)
    tmp = np.empty(4)
    for i in range(n):
        h, na = _prepare(i, acc, dt, ah)
        wx, wy, wz = gyr[i, 0], gyr[i, 1], gyr[i, 2]
        _right_rotate(q, wx * h, wy * h, wz * h, dq, tmp)
        if na > 0.0:
            j = i if sn.shape[0] > 1 else 0
            upol = use_pol[i]
            rows = _model(q, ah, un, upol, sn[j], Cbm, c2[i], s2[i], wpol, min_d2, MODE_NAV, F, J, C, vb, sb)
            if rows == 5:
                counts[C_POL_USED] += 1
            elif rows == -3:
                counts[C_POL_NEAR_ZENITH] += 1
            nr = 5 if rows == 5 else 3
            _grad3(J, F, nr, g)
            for k in range(3):
                d[k] = -(H[k, 0] * g[0] + H[k, 1] * g[1] + H[k, 2] * g[2])
            if nr == 3:
                p = d[0] * un[0] + d[1] * un[1] + d[2] * un[2]
                for k in range(3):
                    d[k] -= p * un[k]
            wn = 0.5 * math.sqrt(wx * wx + wy * wy + wz * wz)
            lam = (gain + rate_gain * wn) * h
            if lam > max_step:
                lam = max_step
            if abs(na - g_ref) > acc_threshold:
                lam *= acc_shrink
                counts[C_ACC_SHRUNK] += 1
            if lam > 0.0:
                for k in range(3):
                    d[k] *= lam
                _left_rotate(q, d[0], d[1], d[2], dq, tmp)
                # BFGS on the same sample's objective: y = g(q⁺) − g(q⁻), s = λD
                _model(q, ah, un, upol and nr == 5, sn[j], Cbm, c2[i], s2[i], wpol, min_d2, MODE_NAV, F, J, C, vb, sb)
                _grad3(J, F, nr, g2)
                sy = 0.0
                ss = 0.0
                yy = 0.0
                for k in range(3):
                    y[k] = g2[k] - g[k]
                    sy += d[k] * y[k]
                    ss += d[k] * d[k]
                    yy += y[k] * y[k]
                if sy > 1e-8 * math.sqrt(ss * yy) and sy > 1e-300:
                    rho = 1.0 / sy
                    for k in range(3):
                        Hy[k] = H[k, 0] * y[0] + H[k, 1] * y[1] + H[k, 2] * y[2]
                    yHy = y[0] * Hy[0] + y[1] * Hy[1] + y[2] * Hy[2]
                    f = (1.0 + rho * yHy) * rho
                    for a in range(3):
                        for b in range(3):
                            H[a, b] += f * d[a] * d[b] - rho * (Hy[a] * d[b] + d[a] * Hy[b])
                    # keep H bounded: an ill-conditioned update (curvature changing between samples) resets
                    tr = H[0, 0] + H[1, 1] + H[2, 2]
                    if not (tr < h_reset) or H[0, 0] <= 0 or H[1, 1] <= 0 or H[2, 2] <= 0:
                        for a in range(3):
                            for b in range(3):
                                H[a, b] = 1.0 if a == b else 0.0
        out[i, 0] = q[0]
        out[i, 1] = q[1]
        out[i, 2] = q[2]
        out[i, 3] = q[3]
    _copy(state[0:4], q)
    _copy(state[4:13], H.ravel())


# --- multiplicative EKF with gyro bias ---------------------------------------------------------------------


@numba.njit(**_NJ)
def _scalar_update(P, hrow, z, r, dx, Ph):
    """Sequential scalar Kalman update of the 6-state error dx with measurement row hrow and residual z."""
    s = r
    for a in range(6):
        v = 0.0
        for b in range(6):
            v += P[a, b] * hrow[b]
        Ph[a] = v
        s += hrow[a] * v
    innov = z
    for a in range(6):
        innov -= hrow[a] * dx[a]
    for a in range(6):
        dx[a] += Ph[a] / s * innov
    for a in range(6):
        for b in range(6):
            P[a, b] -= Ph[a] * Ph[b] / s


@numba.njit(**_NJ)
def _cap_heading(P, v, cap2, w):
    """Scale the attitude error along the unit body vector v (the vertical: heading) so that its variance
    vᵀP_θθv ≤ cap2: P ← S P Sᵀ with S = I + (f − 1)·v̄v̄ᵀ, v̄ = [v, 0], f = √(cap2/vᵀPv). Correlation
    coefficients are kept, P stays positive semi-definite."""
    for a in range(6):
        w[a] = P[a, 0] * v[0] + P[a, 1] * v[1] + P[a, 2] * v[2]
    pv = v[0] * w[0] + v[1] * w[1] + v[2] * w[2]
    if pv <= cap2:
        return
    f1 = math.sqrt(cap2 / pv) - 1.0
    c = f1 * f1 * pv
    for a in range(6):
        va = v[a] if a < 3 else 0.0
        for b in range(6):
            vb_ = v[b] if b < 3 else 0.0
            P[a, b] += f1 * (w[a] * vb_ + va * w[b]) + c * va * vb_


@numba.njit(**_NJ)
def _scalar_update_consider(P, hrow, z, r, dx, Ph, v, heading, bias):
    """:func:`_scalar_update` whose row leaves some states' estimates where they are.

    ``heading``: the attitude error along the unit body vector v (the vertical: heading) is a Schmidt "consider"
    state: its gain is removed, k = P hᵀ/s − c v̄ with c = v̄ᵀP hᵀ/s, and P is updated with that gain (Joseph
    form, which reduces to P − P hᵀh P/s + s c² v̄v̄ᵀ), so it stays the covariance of the estimate actually made.
    ``bias``: the gyro-bias estimate is not moved (its gain is zero) while P takes the row's information as
    if it were: the bias is estimated elsewhere (the input stage) from the same accelerometer information, and
    P keeps the tilt's trust in the accelerometer that estimating it gives."""
    s = r
    for a in range(6):
        t = 0.0
        for b in range(6):
            t += P[a, b] * hrow[b]
        Ph[a] = t
        s += hrow[a] * t
    innov = z
    for a in range(6):
        innov -= hrow[a] * dx[a]
    c = (v[0] * Ph[0] + v[1] * Ph[1] + v[2] * Ph[2]) / s if heading else 0.0
    for a in range(6 if not bias else 3):
        k = Ph[a] / s
        if a < 3 and heading:
            k -= c * v[a]
        dx[a] += k * innov
    for a in range(6):
        for b in range(6):
            P[a, b] -= Ph[a] * Ph[b] / s
    if heading:
        sc2 = s * c * c
        for a in range(3):
            for b in range(3):
                P[a, b] += sc2 * v[a] * v[b]


@numba.njit(**_NJ)
def _transfer_heading(P, v, R, w, d):
    """Move the attitude-error covariance's component along the unit body vector v (the vertical before the
    reset q ← q ⊗ Δr, R = C(Δr)) onto the vertical after it, v⁺ = Rᵀv: P ← T P Tᵀ, T = I + (v̄⁺ − v̄)v̄ᵀ
    (identity on the tilt plane ⊥ v, so the rest of P is left as without a reset). The full first-order
    reset G = I − ½[δθ×] would turn v by half the correction only."""
    for a in range(3):
        d[a] = R[0, a] * v[0] + R[1, a] * v[1] + R[2, a] * v[2] - v[a]
    for a in range(6):
        w[a] = P[a, 0] * v[0] + P[a, 1] * v[1] + P[a, 2] * v[2]
    pv = v[0] * w[0] + v[1] * w[1] + v[2] * w[2]
    for a in range(3):
        for b in range(6):
            P[a, b] += d[a] * w[b]
    for a in range(6):
        for b in range(3):
            P[a, b] += w[a] * d[b]
    for a in range(3):
        for b in range(3):
            P[a, b] += pv * d[a] * d[b]


@numba.njit(**_NJ)
def run_mekf(
    gyr,
    acc,
    dt,
    un,
    use_pol,
    sn,
    Cbm,
    c2,
    s2,
    wpol,
    min_d2,
    gyro_noise,
    bias_noise,
    acc_noise_density,
    pol_noise,
    g_ref,
    acc_threshold,
    acc_inflate,
    max_heading_std,
    consider_heading,
    consider_bias,
    state,
    out,
    std_out,
    bias_out,
    counts,
):
    """Multiplicative EKF: error state [δθ_b (body-frame attitude error), δb (gyro bias)].

    Predict q ← q ⊗ exp((ω − b)dt/2) = q ⊗ Δq, Φ = [[C(Δq)ᵀ, −I dt], [0, I]], Q = diag(σ_g² dt I, σ_b² dt I)
    (σ_g rad/s/√Hz, σ_b rad/s²/√Hz). Update with the shared model rows (body-frame Jacobian): gravity with
    variance acc_noise_density²/h (a density in 1/√Hz: the trust per second is the same at every rate; × acc_inflate²
    when |‖a‖ − g_ref| > acc_threshold), polarization (doubled angle, weight 1) with variance (2·pol_noise)². Scalar sequential updates; reset q ← q ⊗ exp(δθ/2) = q ⊗ Δr.

    Heading is unobservable from gravity: its error is a rotation about the navigation vertical, along
    v_b = C_n^b u_n in body axes, whatever the heading error's size. The exact transition C(Δq)ᵀ (not
    I − [ω×]dt) and, at the reset, the transfer of the covariance's v_b component onto the corrected
    vertical C(Δr)ᵀv_b (:func:`_transfer_heading`) map the unobservable direction exactly from sample to
    sample, so the linearized filter keeps the nonlinear system's null space (observability-constrained EKF,
    Huang, Mourikis & Roumeliotis 2010). Without that, the heading variance, which grows without a heading
    measurement, leaks into the tilt directions and the gravity update "observes" heading through spurious
    correlations (BROAD: heading errors of 50° from a 13° gyro drift). The heading σ is capped at
    ``max_heading_std`` (rad; the vertical's row and column scaled, correlations kept) on samples without a
    polarization row. With ``consider_heading`` the heading is moreover a Schmidt "consider" state on those
    samples (:func:`_scalar_update_consider`): the gravity rows correct tilt and bias but never the heading,
    which then follows the bias-corrected gyro; otherwise they also correct it through the heading–bias
    correlation (right when the model is, but a bias transient at motion onset then swings the heading by up
    to its σ). With ``consider_bias`` (behind the input stage, which has already estimated the gyro bias from
    the same accelerometer and passes its filtered specific force here) the gravity rows leave the bias estimate
    where it is, P taking their information as before (:func:`_scalar_update_consider`); only the polarization
    rows, whose information the stage has not used, move it. Gravity rows re-estimating the bias took the
    stage's low-passed, time-correlated force for white noise and turned the bias about the vertical, which no
    gravity row corrects, so it drove the heading (81° after 60 s on a simulated flight, the stage alone 0.1°).
    state = [q(4), b(3), P(36)]; std_out (N, 3) = attitude-error σ (rad, body axes); bias_out (N, 3) = the bias
    state after each sample (rad/s), or 0 rows: not kept.
    """
    n = gyr.shape[0]
    keep_bias = bias_out.shape[0] == n
    q = state[0:4].copy()
    bias = state[4:7].copy()
    P = state[7:43].copy().reshape(6, 6)
    C = np.empty((3, 3))
    vb = np.empty(3)
    sb = np.empty(3)
    ah = np.empty(3)
    F = np.zeros(5)
    J = np.zeros((5, 4))
    dq = np.empty(4)
    tmp = np.empty(4)
    dx = np.empty(6)
    hrow = np.zeros(6)
    R = np.empty((3, 3))
    Pn = np.empty((6, 6))
    cap2 = max_heading_std * max_heading_std
    Ph = np.empty(6)
    for i in range(n):
        h, na = _prepare(i, acc, dt, ah)
        wx, wy, wz = gyr[i, 0] - bias[0], gyr[i, 1] - bias[1], gyr[i, 2] - bias[2]
        _right_rotate(q, wx * h, wy * h, wz * h, dq, tmp)
        # P ← Φ P Φᵀ + Q with Φ = [[A, −h I], [0, I]], A = C(Δq)ᵀ: R = C(Δq), A[a, k] = R[k, a]. The exact
        # rotation, not I − [ω×]h: its second-order error would turn the vertical by ~(ωh)²/2 per step and
        # leak the (large, unobserved) heading variance into tilt
        _dcm(dq, R)
        # rows 0..2 of ΦP: A P[0:3,:] − h P[3:6,:]
        for a in range(3):
            for b in range(6):
                Pn[a, b] = R[0, a] * P[0, b] + R[1, a] * P[1, b] + R[2, a] * P[2, b] - h * P[3 + a, b]
        for a in range(3):
            for b in range(6):
                Pn[3 + a, b] = P[3 + a, b]
        # (ΦP)Φᵀ: columns 0..2 = (ΦP)[:,0:3] Aᵀ − h (ΦP)[:,3:6]
        for a in range(6):
            for b in range(3):
                P[a, b] = Pn[a, 0] * R[0, b] + Pn[a, 1] * R[1, b] + Pn[a, 2] * R[2, b] - h * Pn[a, 3 + b]
            for b in range(3):
                P[a, 3 + b] = Pn[a, 3 + b]
        qg = gyro_noise * gyro_noise * h
        qb = bias_noise * bias_noise * h
        for a in range(3):
            P[a, a] += qg
            P[3 + a, 3 + a] += qb
        if na > 0.0:
            j = i if sn.shape[0] > 1 else 0
            rows = _model(q, ah, un, use_pol[i], sn[j], Cbm, c2[i], s2[i], 1.0, min_d2, MODE_BODY, F, J, C, vb, sb)
            if rows == 5:
                counts[C_POL_USED] += 1
            elif rows == -3:
                counts[C_POL_NEAR_ZENITH] += 1
            nr = 5 if rows == 5 else 3
            ra = acc_noise_density * acc_noise_density / h
            if abs(na - g_ref) > acc_threshold:
                ra *= acc_inflate * acc_inflate
                counts[C_ACC_SHRUNK] += 1
            rp = 4.0 * pol_noise * pol_noise
            if nr == 3:
                _cap_heading(P, vb, cap2, Ph)
            for a in range(6):
                dx[a] = 0.0
            for r in range(nr):
                hrow[0] = J[r, 0]
                hrow[1] = J[r, 1]
                hrow[2] = J[r, 2]
                # residual z − h(x̂) = −F (the model's error is prediction − measurement)
                hv = nr == 3 and consider_heading
                hb = consider_bias and r < 3
                if hv or hb:
                    _scalar_update_consider(P, hrow, -F[r], ra if r < 3 else rp, dx, Ph, vb, hv, hb)
                else:
                    _scalar_update(P, hrow, -F[r], ra if r < 3 else rp, dx, Ph)
            _right_rotate(q, dx[0], dx[1], dx[2], dq, tmp)
            _dcm(dq, R)
            _transfer_heading(P, vb, R, Ph, hrow)
            bias[0] += dx[3]
            bias[1] += dx[4]
            bias[2] += dx[5]
            for a in range(6):
                for b in range(a + 1, 6):
                    v = 0.5 * (P[a, b] + P[b, a])
                    P[a, b] = v
                    P[b, a] = v
        out[i, 0] = q[0]
        out[i, 1] = q[1]
        out[i, 2] = q[2]
        out[i, 3] = q[3]
        std_out[i, 0] = math.sqrt(max(P[0, 0], 0.0))
        std_out[i, 1] = math.sqrt(max(P[1, 1], 0.0))
        std_out[i, 2] = math.sqrt(max(P[2, 2], 0.0))
        if keep_bias:
            bias_out[i, 0] = bias[0]
            bias_out[i, 1] = bias[1]
            bias_out[i, 2] = bias[2]
    _copy(state[0:4], q)
    _copy(state[4:7], bias)
    _copy(state[7:43], P.ravel())


# --- input checks ----------------------------------------------------------------------------------------------


@numba.njit(**_NJ)
def gravity_means(gyr, acc, dts, w, spread):
    """The specific force ``acc`` (n, 3) carried into the frame the gyro rates ``gyr`` (n, 3) rad/s integrate to
    from the first sample (steps ``dts`` s: one, or one per sample; a rotation-vector update per sample, no coning
    term), and its ``w``-sample moving means: their unit vectors (M, 3) and norms (M,), M = n − w + 1, and, with
    ``spread``, the mean square angle (rad²) between each sample and the mean of the ``w`` samples centred on it
    (else NaN: its arc cosine per sample is a third of the time, and most calls, a scale search's, use the means
    only). One pass for the time-base and unit checks of :mod:`optinav.attitude.checks`, which call it thousands of
    times on short windows, where numpy's per-call overhead was most of the time."""
    n = gyr.shape[0]
    one = dts.shape[0] == 1
    ai = np.empty((n, 3))
    qw, qx, qy, qz = 1.0, 0.0, 0.0, 0.0
    for k in range(n):
        h = dts[0] if one else dts[k]
        qw, qx, qy, qz = qupdate(qw, qx, qy, qz, gyr[k, 0] * h, gyr[k, 1] * h, gyr[k, 2] * h, False, 0.0, 0.0, 0.0)
        vx, vy, vz = qrotate(qw, qx, qy, qz, acc[k, 0], acc[k, 1], acc[k, 2])
        ai[k, 0] = vx
        ai[k, 1] = vy
        ai[k, 2] = vz
    m = n - w + 1
    u = np.empty((max(m, 0), 3))
    nm = np.empty(max(m, 0))
    c0 = np.zeros(3)  # running sums of samples 0 … i − 1 and 0 … i + w − 1
    c1 = np.zeros(3)
    for k in range(min(w, n)):
        for j in range(3):
            c1[j] += ai[k, j]
    ss = 0.0
    for i in range(m):
        if i > 0:
            for j in range(3):
                c0[j] += ai[i - 1, j]
                c1[j] += ai[i + w - 1, j]
        mx = (c1[0] - c0[0]) / w
        my = (c1[1] - c0[1]) / w
        mz = (c1[2] - c0[2]) / w
        r = math.sqrt(mx * mx + my * my + mz * mz)
        if spread:
            x = ai[i + w // 2]
            nx = math.sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2])
            cosang = (x[0] * mx + x[1] * my + x[2] * mz) / (nx * r + 1e-300)
            ss += math.acos(min(max(cosang, -1.0), 1.0)) ** 2
        nm[i] = r
        u[i, 0] = mx / (r + 1e-300)
        u[i, 1] = my / (r + 1e-300)
        u[i, 2] = mz / (r + 1e-300)
    return (ss / max(m, 1) if spread else math.nan), u, nm
