"""Strapdown integration: attitude from angular increments, full attitude/velocity/position mechanization.

Inputs are IMU increments over the sample intervals ``(t[k], t[k+1]]``: ``dtheta`` (N, 3) in rad
(∫ω_ib^b dt) and ``dv`` (N, 3) in m/s (∫f^b dt). Attitude is the quaternion ``q_b^n`` (scalar first,
Hamilton, see :mod:`optinav.core.rotations`); positions are geodetic ``[lat, lon, h]`` (rad, rad, m);
velocities are in the local-level navigation frame ``frame="ned"`` (the default) or ``"enu"``.

One attitude update over an interval (Savage 1998, "Strapdown inertial navigation integration algorithm
design", JGCD 21(1) eqs. 11–16; Titterton & Weston 2004, §11.2)::

    q_k = q(−ζ) ⊗ q_{k−1} ⊗ q(φ),      ζ = ω_in^n · T,      φ = ΣΔθ_i + δφ_coning

with ``q(·)`` the exact rotation-vector quaternion. Coning algorithms (``coning=``; h = sample interval,
λ = Ωh, α = cone half-angle, Ω = coning frequency; the drift is the error of the coning rate along the
cone axis, derived by comparing the algorithm's cone-axis component of ``Σ c Δθ_i×Δθ_j`` under pure coning
with the exact ``½ sin²α (nλ − sin nλ)`` per n-sample interval):

* ``"none"``: φ = Δθ, one update per sample; drift ≈ Ω sin²α λ²/12.
* ``"previous"``: φ_k = Δθ_k + (1/12) Δθ_{k−1}×Δθ_k, one update per sample; drift ≈ Ω sin²α λ⁴/60.
  With unequal steps the 1/12 becomes h_k²/(6 h_{k−1}(h_{k−1} + h_k)) (exact for a linear rate).
* ``"two-sample"``: φ = Δθ1 + Δθ2 + (2/3) Δθ1×Δθ2; drift ≈ Ω sin²α λ⁴/60.
* ``"three-sample"``: φ = ΣΔθ + (9/20 Δθ1 + 27/20 Δθ2)×Δθ3; drift ≈ Ω sin²α λ⁶/280.
* ``"four-sample"``: φ = ΣΔθ + (54 Δθ1 + 92 Δθ2 + 214 Δθ3)/105 × Δθ4; drift ≈ Ω sin²α λ⁸/1260.

:func:`coning_drift_rate` gives the exact-in-λ first-order (in sin²α) expressions.
The multi-sample coefficients are the coning-optimal ones of the form ``(Σ c_i Δθ_i) × Δθ_n`` (Ignagni
1990, "Optimal strapdown attitude integration algorithms", JGCD 13(2); the same form as Yan Gongmin's
PSINS ``conepolyn``); the sculling terms use the same coefficients (Savage's coning/sculling equivalence):
``δv = (Σ c_i Δθ_i)×Δv_n + (Σ c_i Δv_i)×Δθ_n``. With ``"none"`` there is no sculling term.

Output epochs: ``"none"`` and ``"previous"`` give the attitude at every sample time ``t[0..N]``; an
n-sample algorithm gives it at ``t[0], t[n], t[2n], …`` and, when ``N`` is not a multiple of n, at
``t[N]`` after integrating the trailing ``N mod n`` samples with the algorithm of that order.
:func:`output_indices` returns the sample indices of the outputs.

Sequential loops are small ``numba`` kernels behind this numpy API (the layout of pyins). The
mechanization runs in ENU internally (as PSINS); ``frame="ned"`` only rotates the inputs and outputs.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numba
import numpy as np

from optinav.core import earth as _earth
from optinav.core._quat import qrotate, qupdate
from optinav.core.results import Result
from optinav.core.rotations import DEFAULT_FRAME, C_ENU_NED, frame_name, quat_conjugate, quat_from_dcm, quat_multiply
from optinav.core.validate import as_float_array, check_timestamps
from optinav.errors import OptinavError

__all__ = [
    "CONING_ALGORITHMS",
    "NavSolution",
    "attitude_update",
    "AttitudeStream",
    "mechanize",
    "output_indices",
    "rotation_increments",
    "coning_drift_rate",
]

#: coning algorithm name → samples per attitude update
CONING_ALGORITHMS = {"none": 1, "previous": 1, "two-sample": 2, "three-sample": 3, "four-sample": 4}

# Row r: coefficients c_1..c_{r-1} of the r-sample correction (Σ c_i Δθ_i) × Δθ_r (module docstring).
_CS = np.zeros((5, 4))
_CS[2, :1] = [2.0 / 3.0]
_CS[3, :2] = [9.0 / 20.0, 27.0 / 20.0]
_CS[4, :3] = [54.0 / 105.0, 92.0 / 105.0, 214.0 / 105.0]

#: quaternion of C_ENU^NED (a proper rotation: π about (1, 1, 0)/√2); q_b^enu = _Q_NED_TO_ENU ⊗ q_b^ned
_Q_NED_TO_ENU = quat_from_dcm(C_ENU_NED)


# --- numba kernels ------------------------------------------------------------------------------------


@numba.njit(cache=True, inline="always")
def _prev_coef(cprev, hp, h):
    # For a linear rate over (−h_{k−1}, h_k], ½∫α×ω over the current step is (h³/12) a×b and
    # Δθ_{k−1}×Δθ_k = h_{k−1} h (h_{k−1} + h)/2 a×b, so the exact coefficient is h²/(6 h_{k−1}(h_{k−1}+h))
    # (= 1/12 for equal steps); the same coefficient serves the sculling term (Savage's equivalence).
    return cprev * 2.0 * h * h / (hp * (hp + h))


@numba.njit(cache=True)
def _attitude_single(q0, dth, zeta, zstep, cprev, hs, out, store, prev):
    """One update per sample; φ_k = Δθ_k + c_k Δθ_{k−1}×Δθ_k; zstep < 0: no navigation-frame rotation.

    c_k = cprev for equal steps; with intervals ``hs`` (N,) it is ``cprev · 2h_k²/(h_{k−1}(h_{k−1}+h_k))``.
    ``prev`` (4,): the increment before ``dth[0]`` and its interval (> 0; 0: none, the log's start).
    """
    w, x, y, z = q0[0], q0[1], q0[2], q0[3]
    px, py, pz = prev[0], prev[1], prev[2]
    n = dth.shape[0]
    irregular = hs.shape[0] == n
    c = cprev
    if irregular and n > 0 and prev[3] > 0.0:
        c = _prev_coef(cprev, prev[3], hs[0])
    if store:
        out[0, 0] = w
        out[0, 1] = x
        out[0, 2] = y
        out[0, 3] = z
    for k in range(n):
        ax, ay, az = dth[k, 0], dth[k, 1], dth[k, 2]
        if irregular and k > 0:
            c = _prev_coef(cprev, hs[k - 1], hs[k])
        fx = ax + c * (py * az - pz * ay)
        fy = ay + c * (pz * ax - px * az)
        fz = az + c * (px * ay - py * ax)
        px, py, pz = ax, ay, az
        i = k * zstep if zstep > 0 else 0  # zstep: 1 per sample, 0 constant, -1 none (value unused)
        w, x, y, z = qupdate(w, x, y, z, fx, fy, fz, zstep >= 0, zeta[i, 0], zeta[i, 1], zeta[i, 2])
        if store:
            out[k + 1, 0] = w
            out[k + 1, 1] = x
            out[k + 1, 2] = y
            out[k + 1, 3] = z
    if not store:
        out[0, 0] = w
        out[0, 1] = x
        out[0, 2] = y
        out[0, 3] = z


@numba.njit(cache=True)
def _attitude_multi(q0, dth, zeta, zstep, idx, cs, out, store):
    """One update per group idx[j]..idx[j+1] with the r-sample correction of row r of ``cs``."""
    w, x, y, z = q0[0], q0[1], q0[2], q0[3]
    if store:
        out[0, 0] = w
        out[0, 1] = x
        out[0, 2] = y
        out[0, 3] = z
    for j in range(idx.shape[0] - 1):
        i0 = idx[j]
        i1 = idx[j + 1]
        r = i1 - i0
        sx = sy = sz = 0.0
        cx = cy = cz = 0.0
        zx = zy = zz = 0.0
        for i in range(r):
            sx += dth[i0 + i, 0]
            sy += dth[i0 + i, 1]
            sz += dth[i0 + i, 2]
            if i < r - 1:
                c = cs[r, i]
                cx += c * dth[i0 + i, 0]
                cy += c * dth[i0 + i, 1]
                cz += c * dth[i0 + i, 2]
            if zstep >= 0:
                m = (i0 + i) * zstep
                zx += zeta[m, 0]
                zy += zeta[m, 1]
                zz += zeta[m, 2]
        lx, ly, lz = dth[i1 - 1, 0], dth[i1 - 1, 1], dth[i1 - 1, 2]
        fx = sx + cy * lz - cz * ly
        fy = sy + cz * lx - cx * lz
        fz = sz + cx * ly - cy * lx
        w, x, y, z = qupdate(w, x, y, z, fx, fy, fz, zstep >= 0, zx, zy, zz)
        if store:
            out[j + 1, 0] = w
            out[j + 1, 1] = x
            out[j + 1, 2] = y
            out[j + 1, 3] = z
    if not store:
        out[0, 0] = w
        out[0, 1] = x
        out[0, 2] = y
        out[0, 3] = z


@numba.njit(cache=True, inline="always")
def _gravity(s2, h, ep):
    # Same formulas as optinav.core.earth.gravity (tested equal there); ep from _earth_params.
    a, e2, f, gmodel, ge, ksom, m = ep[0], ep[1], ep[3], ep[4], ep[5], ep[6], ep[7]
    if gmodel == 1.0:
        return ge * (1.0 + 5.27094e-3 * s2 + 2.32718e-5 * s2 * s2) - 3.086e-6 * h
    g0 = ge * (1.0 + ksom * s2) / np.sqrt(1.0 - e2 * s2)
    return g0 * (1.0 - 2.0 / a * (1.0 + f + m - 2.0 * f * s2) * h + 3.0 / (a * a) * h * h)


@numba.njit(cache=True)
def _mechanize_enu(dth, dv, t, idx, q0, v0, p0, cs, cprev, scul, ep, hold, out_q, out_v, out_p):
    """ENU mechanization, one update per group idx[j]..idx[j+1] (see mechanize())."""
    a, e2, wie = ep[0], ep[1], ep[2]
    w, x, y, z = q0[0], q0[1], q0[2], q0[3]
    ve, vn, vu = v0[0], v0[1], v0[2]
    lat, lon, h = p0[0], p0[1], p0[2]
    h_hold = p0[2]
    ae = an = au = 0.0  # previous nav-frame acceleration, for the mid-interval extrapolation
    ptx = pty = ptz = 0.0  # previous sample increments ("previous" algorithm)
    pvx = pvy = pvz = 0.0
    t_prev = 1.0
    out_q[0, 0], out_q[0, 1], out_q[0, 2], out_q[0, 3] = w, x, y, z
    out_v[0, 0], out_v[0, 1], out_v[0, 2] = ve, vn, vu
    out_p[0, 0], out_p[0, 1], out_p[0, 2] = lat, lon, h
    for j in range(idx.shape[0] - 1):
        i0 = idx[j]
        i1 = idx[j + 1]
        r = i1 - i0
        T = t[i1] - t[i0]
        # --- body-frame increments with coning and sculling corrections
        sx = sy = sz = 0.0
        ux = uy = uz = 0.0
        cp = _prev_coef(cprev, t_prev, T) if j > 0 else 0.0
        t_prev = T
        cx, cy, cz = cp * ptx, cp * pty, cp * ptz
        dx, dy, dz = cp * pvx, cp * pvy, cp * pvz
        for i in range(r):
            k = i0 + i
            sx += dth[k, 0]
            sy += dth[k, 1]
            sz += dth[k, 2]
            ux += dv[k, 0]
            uy += dv[k, 1]
            uz += dv[k, 2]
            if i < r - 1:
                c = cs[r, i]
                cx += c * dth[k, 0]
                cy += c * dth[k, 1]
                cz += c * dth[k, 2]
                dx += c * dv[k, 0]
                dy += c * dv[k, 1]
                dz += c * dv[k, 2]
        lx, ly, lz = dth[i1 - 1, 0], dth[i1 - 1, 1], dth[i1 - 1, 2]
        mx, my, mz = dv[i1 - 1, 0], dv[i1 - 1, 1], dv[i1 - 1, 2]
        ptx, pty, ptz = lx, ly, lz
        pvx, pvy, pvz = mx, my, mz
        fx = sx + cy * lz - cz * ly
        fy = sy + cz * lx - cx * lz
        fz = sz + cx * ly - cy * lx
        # rotation compensation ½ Δθ×Δv (Savage 1998 eq. 55) + sculling
        bx = ux + 0.5 * (sy * uz - sz * uy)
        by = uy + 0.5 * (sz * ux - sx * uz)
        bz = uz + 0.5 * (sx * uy - sy * ux)
        if scul:
            bx += cy * mz - cz * my + dy * lz - dz * ly
            by += cz * mx - cx * mz + dz * lx - dx * lz
            bz += cx * my - cy * mx + dx * ly - dy * lx
        # --- Earth terms at the extrapolated mid-interval state
        vme, vmn, vmu = ve + 0.5 * T * ae, vn + 0.5 * T * an, vu + 0.5 * T * au
        sl = np.sin(lat)
        wq = np.sqrt(1.0 - e2 * sl * sl)
        rm = a * (1.0 - e2) / (wq * wq * wq) + h
        rn = a / wq + h
        latm = lat + 0.5 * T * vmn / rm
        hm = h + 0.5 * T * vmu
        sl = np.sin(latm)
        cl = np.cos(latm)
        s2 = sl * sl
        wq = np.sqrt(1.0 - e2 * s2)
        rm = a * (1.0 - e2) / (wq * wq * wq) + hm
        rn = a / wq + hm
        g = _gravity(s2, hm, ep)
        wiex, wiey, wiez = 0.0, wie * cl, wie * sl
        wenx, weny, wenz = -vmn / rm, vme / rn, vme * sl / (cl * rn)
        zx, zy, zz = (wiex + wenx) * T, (wiey + weny) * T, (wiez + wenz) * T
        # --- velocity: C_b^n(k−1) Δv_sf^b, then the half navigation-frame rotation −½ ζ×(·)
        nx, ny, nz = qrotate(w, x, y, z, bx, by, bz)
        nx, ny, nz = (nx - 0.5 * (zy * nz - zz * ny), ny - 0.5 * (zz * nx - zx * nz), nz - 0.5 * (zx * ny - zy * nx))
        # gravity and Coriolis: g^n − (2ω_ie + ω_en)×v
        ox, oy, oz = 2.0 * wiex + wenx, 2.0 * wiey + weny, 2.0 * wiez + wenz
        gx = -(oy * vmu - oz * vmn)
        gy = -(oz * vme - ox * vmu)
        gz = -g - (ox * vmn - oy * vme)
        ve1 = ve + nx + gx * T
        vn1 = vn + ny + gy * T
        vu1 = vu + nz + gz * T
        if hold:
            vu1 = 0.0
        # --- position: trapezoidal velocity, radii at mid-interval
        ae, an, au = (ve1 - ve) / T, (vn1 - vn) / T, (vu1 - vu) / T
        lat += 0.5 * (vn + vn1) * T / rm
        lon += 0.5 * (ve + ve1) * T / (rn * cl)
        if hold:
            h = h_hold
        else:
            h += 0.5 * (vu + vu1) * T
        ve, vn, vu = ve1, vn1, vu1
        # --- attitude: q(−ζ) ⊗ q ⊗ q(φ)
        w, x, y, z = qupdate(w, x, y, z, fx, fy, fz, True, zx, zy, zz)
        out_q[j + 1, 0], out_q[j + 1, 1], out_q[j + 1, 2], out_q[j + 1, 3] = w, x, y, z
        out_v[j + 1, 0], out_v[j + 1, 1], out_v[j + 1, 2] = ve, vn, vu
        out_p[j + 1, 0], out_p[j + 1, 1], out_p[j + 1, 2] = lat, lon, h


# --- helpers ------------------------------------------------------------------------------------------


def _coning(coning: str) -> tuple[str, int]:
    key = str(coning).lower()
    if key not in CONING_ALGORITHMS:
        raise OptinavError(
            f"unknown coning algorithm {coning!r}", f"use one of {', '.join(repr(k) for k in CONING_ALGORITHMS)}"
        )
    return key, CONING_ALGORITHMS[key]


def output_indices(n_increments: int, coning: str = "previous") -> np.ndarray:
    """Sample indices k (into ``t``) at which :func:`attitude_update`/:func:`mechanize` give outputs.

    Parameters
    ----------
    n_increments : int
        Number of increments N.
    coning : str
        Algorithm (multi-sample algorithms output once per group).

    Returns
    -------
    (M + 1,) int ndarray
        The indices.
    """
    coning, n = _coning(coning)
    n_increments = int(n_increments)
    if n_increments < 1:
        raise OptinavError(f"{n_increments} increments given", "pass at least one IMU sample interval")
    idx = np.arange(0, n_increments + 1, n, dtype=np.int64)
    if idx[-1] != n_increments:
        idx = np.append(idx, n_increments)
    return idx


def _as_quat0(q0) -> np.ndarray:
    a = as_float_array(q0, "q0")
    if a.shape == (3, 3):
        if abs(np.linalg.det(a) - 1.0) > 1e-6 or not np.allclose(a @ a.T, np.eye(3), atol=1e-6):
            raise OptinavError(
                "q0 is a 3×3 matrix but not a rotation matrix (C_b^n)",
                "pass an orthonormal C_b^n with determinant +1 or a unit quaternion",
            )
        return quat_from_dcm(a)
    if a.shape != (4,):
        raise OptinavError(
            f"q0 has shape {a.shape}, expected a quaternion (4,) or C_b^n (3, 3)",
            "pass the initial attitude q_b^n as [w, x, y, z]",
        )
    n = np.linalg.norm(a)
    if abs(n - 1.0) > 1e-6:
        raise OptinavError(f"q0 is not a unit quaternion (norm {n:.6g})", "normalize the initial attitude")
    return a / n


def _as_increments(x, name: str) -> np.ndarray:
    a = as_float_array(x, name, last_dims=(3,))
    if a.ndim != 2 or a.shape[0] < 1:
        raise OptinavError(
            f"{name} has shape {a.shape}, expected (N, 3) with N ≥ 1", "pass one increment per sample interval"
        )
    return np.ascontiguousarray(a)


def rotation_increments(dtheta, coning: str = "previous", dt=None) -> np.ndarray:
    """Coning-compensated body rotation vectors φ, one per update (see module docstring).

    Vectorized numpy; the updates are at the sample indices :func:`output_indices`.

    Parameters
    ----------
    dtheta : (N, 3) array
        Body angular increments [rad].
    coning : str
        Algorithm (module docstring).
    dt : (N,) array or None
        Sample intervals [s], adapting the "previous" coefficient to unequal steps.

    Returns
    -------
    (M, 3) ndarray
        φ [rad].
    """
    dth = _as_increments(dtheta, "dtheta")
    coning, n = _coning(coning)
    if coning == "none":
        return dth.copy()
    if coning == "previous":
        c = np.full(dth.shape[0], 1.0 / 12.0)
        if dt is not None:
            h = as_float_array(dt, "dt")
            if h.shape != (dth.shape[0],) or np.any(h <= 0):
                raise OptinavError(
                    f"dt has shape {h.shape} or non-positive steps, expected ({dth.shape[0]},) > 0",
                    "give one positive interval per increment",
                )
            c[1:] = h[1:] ** 2 / (6.0 * h[:-1] * (h[:-1] + h[1:]))
        prev = np.vstack([np.zeros((1, 3)), dth[:-1]])
        return dth + c[:, None] * np.cross(prev, dth)
    idx = output_indices(dth.shape[0], coning)
    out = np.empty((idx.size - 1, 3))
    full = (dth.shape[0] // n) * n
    if full:
        g = dth[:full].reshape(-1, n, 3)
        cm = np.einsum("i,mij->mj", _CS[n, : n - 1], g[:, : n - 1])
        out[: full // n] = g.sum(1) + np.cross(cm, g[:, -1])
    if full != dth.shape[0]:
        tail = dth[full:]
        r = tail.shape[0]
        cm = _CS[r, : r - 1] @ tail[: r - 1]
        out[-1] = tail.sum(0) + np.cross(cm, tail[-1])
    return out


def coning_drift_rate(coning: str, half_angle: float, frequency: float, dt: float) -> float:
    """Coning drift of an algorithm under classical coning, to first order in sin²α.

    Exact in λ = Ω·dt: ``sin²α [2(1 − cos λ) Σ_m a_m sin(mλ) − ½(nλ − sin nλ)] / (n·dt)`` with a_m the sum of
    the coefficients of the cross products m samples apart (Ignagni 1990). Negative: the algorithm
    under-estimates the coning rotation about the cone axis.

    Parameters
    ----------
    coning : str
        Algorithm (module docstring).
    half_angle : float
        Cone half-angle α [rad].
    frequency : float
        Coning frequency Ω/2π [Hz].
    dt : float
        Sample interval [s].

    Returns
    -------
    float
        Drift rate [rad/s].
    """
    coning, n = _coning(coning)
    lam = 2.0 * np.pi * frequency * dt
    s2 = np.sin(half_angle) ** 2
    if coning == "previous":
        alg = 2.0 * (1.0 - np.cos(lam)) * np.sin(lam) / 12.0
    else:
        alg = 2.0 * (1.0 - np.cos(lam)) * sum(_CS[n, n - 1 - m] * np.sin(m * lam) for m in range(1, n))
    return float(s2 * (alg - 0.5 * (n * lam - np.sin(n * lam))) / (n * dt))


def attitude_update(
    q0, dtheta, *, coning: str = "previous", omega_in_n=None, dt=None, final_only: bool = False
) -> np.ndarray:
    """Integrate body angular increments into the attitude ``q_b^n``.

    Parameters
    ----------
    q0 : (4,) or (3, 3) array
        Unit quaternion ``q_b^n`` [w, x, y, z] [-] at ``t[0]``, or a ``C_b^n`` [-].
    dtheta : (N, 3) array
        Body angular increments ∫ω_ib^b dt over each sample interval [rad].
    coning : str
        Algorithm (module docstring): "none", "previous", "two-sample", "three-sample", "four-sample".
    omega_in_n : (3,) or (N, 3) array or None
        Rate of the navigation frame w.r.t. inertial space, navigation axes [rad/s], constant or per sample;
        None: the navigation frame is inertial.
    dt : float or (N,) array or None
        Sample intervals [s]; required with ``omega_in_n``. Per-sample intervals also adapt the "previous"
        coefficient to unequal steps (``_prev_coef``); the multi-sample algorithms assume equal steps within a
        group.
    final_only : bool
        Return only the last attitude without storing the history (fastest).

    Returns
    -------
    (M + 1, 4) or (4,) ndarray
        ``q_b^n`` [-] at the sample indices :func:`output_indices` (``M = N`` for "none"/"previous"), or the last
        one with ``final_only``.
    """
    q = _as_quat0(q0)
    dth = _as_increments(dtheta, "dtheta")
    n_samp = dth.shape[0]
    coning, n = _coning(coning)
    d = None
    if dt is not None:
        d = as_float_array(dt, "dt")
        if d.ndim > 1 or (d.ndim == 1 and d.shape[0] != n_samp):
            raise OptinavError(
                f"dt has shape {d.shape}, expected a scalar or ({n_samp},)", "give one interval or one per increment"
            )
        if np.any(d <= 0):
            raise OptinavError("dt has non-positive intervals", "pass positive sample intervals in s")
    if omega_in_n is None:
        zeta, zstep = np.zeros((1, 3)), -1
    else:
        if d is None:
            raise OptinavError("omega_in_n needs the sample intervals dt", "pass dt (scalar or (N,) in s)")
        w = as_float_array(omega_in_n, "omega_in_n", last_dims=(3,))
        if w.ndim not in (1, 2) or (w.ndim == 2 and w.shape[0] != n_samp):
            raise OptinavError(
                f"omega_in_n has shape {w.shape}, expected (3,) or ({n_samp}, 3)", "give one rate or one per increment"
            )
        if w.ndim == 1 and d.ndim == 0:
            zeta, zstep = (w * d)[None, :], 0
        else:
            # a new writable array in every case: a read-only broadcast view when w·dt had the full shape
            # already compiled the kernels a second time (a second type signature)
            zeta = np.multiply(w, d[..., None] if d.ndim else d, out=np.empty((n_samp, 3)))
            zstep = 1
    hs = np.ascontiguousarray(d) if d is not None and d.ndim == 1 else np.empty(0)
    if n == 1:
        out = np.empty((1 if final_only else n_samp + 1, 4))
        _attitude_single(
            q, dth, zeta, zstep, 1.0 / 12.0 if coning == "previous" else 0.0, hs, out, not final_only, np.zeros(4)
        )
    else:
        idx = output_indices(n_samp, coning)
        out = np.empty((1 if final_only else idx.size, 4))
        _attitude_multi(q, dth, zeta, zstep, idx, _CS, out, not final_only)
    return out[0] if final_only else out


class AttitudeStream:
    """:func:`attitude_update` ("previous" or "none" coning, per-sample intervals) over the consecutive blocks of one
    log: the quaternion and the coning state (the last increment and its interval) are carried from block to
    block, so the blocks give the attitudes of one call over the whole log bit for bit.

    Parameters
    ----------
    q0 : (4,) or (3, 3) array
        ``q_b^n`` [w, x, y, z] [-] (or ``C_b^n``) at the first epoch.
    coning : str
        "previous" or "none".
    omega_in_n : (3,) array or None
        Constant rate of the navigation frame w.r.t. inertial space, navigation axes [rad/s]; None: inertial.
    """

    def __init__(self, q0, *, coning: str = "previous", omega_in_n=None):
        coning, n = _coning(coning)
        if n != 1:
            raise OptinavError(
                f"AttitudeStream integrates sample by sample, not {coning!r}", "use 'previous' or 'none'"
            )
        self.q = _as_quat0(q0)
        self._cprev = 1.0 / 12.0 if coning == "previous" else 0.0
        self._w = None if omega_in_n is None else as_float_array(omega_in_n, "omega_in_n", last_dims=(3,))
        self._prev = np.zeros(4)  # the last increment [rad] and its interval [s]; 0: none yet

    def update(self, dtheta, dt) -> np.ndarray:
        """Integrate the next increments of the log.

        Parameters
        ----------
        dtheta : (N, 3) array
            Body angular increments [rad], continuing the previous block's.
        dt : (N,) array
            Their intervals [s].

        Returns
        -------
        (N + 1, 4) ndarray
            ``q_b^n`` [-] at the block's epochs, the first the attitude carried in (N = 0: that one alone).
        """
        dth = np.ascontiguousarray(as_float_array(dtheta, "dtheta", last_dims=(3,)).reshape(-1, 3))
        d = np.ascontiguousarray(as_float_array(dt, "dt").reshape(-1))
        n = dth.shape[0]
        if d.shape[0] != n or np.any(d <= 0):
            raise OptinavError(f"dt needs {n} positive intervals, got shape {d.shape}", "pass one interval per row")
        out = np.empty((n + 1, 4))
        if n == 0:
            out[0] = self.q
            return out
        if self._w is None:
            zeta, zstep = np.zeros((1, 3)), -1
        else:
            zeta, zstep = np.ascontiguousarray(self._w * d[..., None]), 1
        _attitude_single(self.q, dth, zeta, zstep, self._cprev, d, out, True, self._prev)
        self.q = out[-1].copy()
        self._prev = np.append(dth[-1], d[-1])
        return out


# --- full mechanization -------------------------------------------------------------------------------


@dataclass
class NavSolution(Result):
    """Strapdown navigation solution at the output epochs (:func:`output_indices`), in the navigation frame
    ``frame`` ("ned" or "enu", as :func:`mechanize` was given)."""

    SCHEMA = "optinav.nav_solution"
    VERSION = 2
    #: every file optinav wrote names its frame; one without it is read as the ENU of the former default
    MISSING_MEANT = {"frame": "enu"}

    t: np.ndarray = field(metadata={"unit": "s"})
    q_b_n: np.ndarray = field(metadata={"unit": ""})  #: (M+1, 4) scalar-first quaternion q_b^n
    vel_n: np.ndarray = field(metadata={"unit": "m/s"})  #: (M+1, 3) in the navigation frame
    pos: np.ndarray = field(metadata={"unit": "rad, rad, m"})  #: (M+1, 3) [lat, lon, h]
    frame: str = field(metadata={"unit": "-"})
    earth: str = field(default="wgs84", metadata={"unit": "-"})
    coning: str = field(default="previous", metadata={"unit": "-"})
    index: np.ndarray | None = field(default=None, metadata={"unit": ""})  #: sample index of each output


def _earth_params(e: _earth.EarthConstants) -> np.ndarray:
    m = e.omega_ie**2 * e.a**2 * e.b / e.gm
    gmodel = {"somigliana": 0.0, "psins": 1.0}[e.gravity_model]
    return np.array([e.a, e.e2, e.omega_ie, e.f, gmodel, e.g_e, e.k_somigliana, m])


def mechanize(
    dtheta,
    dv,
    t,
    q0,
    vel0,
    pos0,
    frame: str = DEFAULT_FRAME,
    earth="wgs84",
    coning: str = "previous",
    sculling: bool = True,
    vertical: str = "free",
) -> NavSolution:
    """Strapdown attitude/velocity/position integration in a local-level frame (Savage 1998; T&W ch. 11).

    Each update: φ and Δv_sf^b with coning/sculling; Earth rate, transport rate, gravity and Coriolis at the
    mid-interval state extrapolated from the previous acceleration; ``Δv^n = (I − ½[ζ×]) C_b^n Δv_sf^b +
    (g^n − (2ω_ie^n + ω_en^n)×v^n) T``; trapezoidal position; ``q ← q(−ζ) ⊗ q ⊗ q(φ)``. Second-order accurate in
    T for slowly moving bases (no high-rate velocity/position algorithms).

    Parameters
    ----------
    dtheta : (N, 3) array
        Body increments ∫ω_ib^b dt over ``(t[k], t[k+1]]`` [rad].
    dv : (N, 3) array
        Body increments ∫f^b dt over ``(t[k], t[k+1]]`` [m/s].
    t : (N+1,) array
        Sample times [s], strictly increasing (irregular steps are fine).
    q0 : (4,) or (3, 3) array
        Initial ``q_b^n`` or ``C_b^n`` at ``t[0]`` [-].
    vel0 : (3,) array
        Initial velocity in ``frame`` [m/s].
    pos0 : (3,) array
        Initial ``[lat, lon, height]`` [rad, rad, m].
    frame : str
        ``"enu"`` or ``"ned"`` navigation frame.
    earth : str or EarthConstants
        ``"wgs84"``, ``"psins"`` or a constant set.
    coning : str
        Attitude algorithm (module docstring).
    sculling : bool
        Add the sculling term of the same algorithm to the velocity increment (the ½Δθ×Δv rotation
        compensation is always applied).
    vertical : str
        ``"free"`` integrates the (unstable) vertical channel; ``"hold"`` keeps h = h0 and v_up = 0.

    Returns
    -------
    NavSolution
        Attitude ``q_b^n``, velocity [m/s] and position [rad, rad, m] at the output epochs.
    """
    dth = _as_increments(dtheta, "dtheta")
    dvb = _as_increments(dv, "dv")
    if dvb.shape != dth.shape:
        raise OptinavError(f"dv has shape {dvb.shape} but dtheta has {dth.shape}", "pass matching increments")
    tt = check_timestamps(t, "t")
    if tt.size != dth.shape[0] + 1:
        raise OptinavError(
            f"t has {tt.size} samples for {dth.shape[0]} increments",
            "pass N+1 times for N increments (t[k] to t[k+1] bounds increment k)",
        )
    fr = frame_name(frame)
    e = _earth.constants(earth)
    q = _as_quat0(q0)
    v = as_float_array(vel0, "vel0", last_dims=(3,))
    p = as_float_array(pos0, "pos0", last_dims=(3,))
    if v.shape != (3,) or p.shape != (3,):
        raise OptinavError("vel0 and pos0 must be single 3-vectors", "pass the state at t[0]")
    if abs(p[0]) >= np.pi / 2 - 1e-6:
        raise OptinavError(
            f"latitude {np.degrees(p[0]):.6g}° is at or beyond a pole",
            "pass pos0 = [lat, lon, h] in rad with |lat| < 90°",
        )
    if vertical not in ("free", "hold"):
        raise OptinavError(f"unknown vertical mode {vertical!r}", "use 'free' or 'hold'")
    coning, n = _coning(coning)
    idx = output_indices(dth.shape[0], coning) if n > 1 else np.arange(dth.shape[0] + 1, dtype=np.int64)
    if fr == "ned":
        q = quat_multiply(_Q_NED_TO_ENU, q)
        v = C_ENU_NED @ v
    m = idx.size
    out_q, out_v, out_p = np.empty((m, 4)), np.empty((m, 3)), np.empty((m, 3))
    _mechanize_enu(
        dth,
        dvb,
        tt,
        idx,
        q,
        v.copy(),
        p.copy(),
        _CS,
        1.0 / 12.0 if coning == "previous" else 0.0,
        bool(sculling) and coning != "none",
        _earth_params(e),
        vertical == "hold",
        out_q,
        out_v,
        out_p,
    )
    if fr == "ned":
        out_q = quat_multiply(quat_conjugate(_Q_NED_TO_ENU), out_q)
        out_v = out_v @ C_ENU_NED.T
    return NavSolution(
        t=tt[idx], q_b_n=out_q, vel_n=out_v, pos=out_p, frame=fr, earth=e.name.lower(), coning=str(coning), index=idx
    )
