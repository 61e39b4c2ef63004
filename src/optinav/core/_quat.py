"""The one set of numba quaternion kernels, shared by :mod:`optinav.core.strapdown` and the attitude
estimators (private; the numpy API is :mod:`optinav.core.rotations`).

Quaternions ``[w, x, y, z]`` (Hamilton, docs/conventions.md) passed and returned as four scalars, so the
kernels inline into the per-sample loops without arrays. ``rv2q`` is the exponential of a rotation vector in
closed form, cos(|φ|/2) and sin(|φ|/2)/|φ|, which is exact to rounding down to the smallest angles; only below
|φ| = 1e-8 rad, where 0/0 looms, the series 1 − |φ|²/8 + |φ|⁴/384 and ½ − |φ|²/48 takes over (its first
omitted terms are below 1e-50). A longer series up to 0.1 rad (the strapdown's former choice) is as accurate
but not bit-identical, and the attitude estimators' results must not move: the published quasi-Newton filter
diverges on BROAD trial 16 and a last-bit change there moves its error from 56° to 70°.
"""

from __future__ import annotations

import math

import numba

# numba's on-disk cache of a caller (strapdown, attitude/_kernels, attitude/_iframe) holds these kernels inlined
# and is keyed on the caller's file only: after editing this file, delete those modules' __pycache__/*.nb[ic]
_NJ = dict(cache=True, nogil=True, inline="always")

#: below this |φ|² (rad²) :func:`rv2q` uses the series (|φ| < 1e-8 rad)
SERIES_N2 = 1e-16


@numba.njit(**_NJ)
def rv2q(x, y, z):
    """Quaternion exp(φ/2) of the rotation vector φ = (x, y, z) rad, as (w, x, y, z)."""
    n2 = x * x + y * y + z * z
    if n2 < SERIES_N2:
        u = 0.25 * n2  # (|φ|/2)²
        c = 1.0 - u * (1.0 / 2.0 - u * (1.0 / 24.0))
        s = 0.5 - u * (1.0 / 12.0)
        return c, s * x, s * y, s * z
    n = math.sqrt(n2)
    s = math.sin(0.5 * n) / n
    return math.cos(0.5 * n), s * x, s * y, s * z


@numba.njit(**_NJ)
def qmul(aw, ax, ay, az, bw, bx, by, bz):
    """Hamilton product a ⊗ b, as (w, x, y, z)."""
    return (
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    )


@numba.njit(**_NJ)
def qnormalize(w, x, y, z):
    """q / |q|, as (w, x, y, z)."""
    n = math.sqrt(w * w + x * x + y * y + z * z)
    return w / n, x / n, y / n, z / n


@numba.njit(**_NJ)
def qrotate(w, x, y, z, vx, vy, vz):
    """C(q) v = q ⊗ [0, v] ⊗ q* for a unit q (e.g. v_n from v_b with q = q_b^n), as (x, y, z)."""
    # v + 2w (u × v) + 2 u × (u × v), u = (x, y, z)
    tx = 2.0 * (y * vz - z * vy)
    ty = 2.0 * (z * vx - x * vz)
    tz = 2.0 * (x * vy - y * vx)
    return (vx + w * tx + (y * tz - z * ty), vy + w * ty + (z * tx - x * tz), vz + w * tz + (x * ty - y * tx))


@numba.njit(**_NJ)
def qrotate_inv(w, x, y, z, vx, vy, vz):
    """C(q)ᵀ v = q* ⊗ [0, v] ⊗ q for a unit q (e.g. v_b from v_n with q = q_b^n), as (x, y, z)."""
    return qrotate(w, -x, -y, -z, vx, vy, vz)


@numba.njit(**_NJ)
def qupdate(w, x, y, z, fx, fy, fz, nav, zx, zy, zz):
    """Attitude step q ← exp(−ζ/2) ⊗ q ⊗ exp(φ/2), normalized: body rotation vector φ, then (if ``nav``) the
    navigation-frame rotation ζ over the step."""
    bw, bx, by, bz = rv2q(fx, fy, fz)
    w, x, y, z = qmul(w, x, y, z, bw, bx, by, bz)
    if nav:
        nw, nx, ny, nz = rv2q(-zx, -zy, -zz)
        w, x, y, z = qmul(nw, nx, ny, nz, w, x, y, z)
    return qnormalize(w, x, y, z)
