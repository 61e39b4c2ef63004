"""numba kernels of the norm observation and of the poses' statistics (private; the numpy APIs are
:func:`optinav.multipos.model.norm_residuals` and :func:`optinav.multipos.accel.pose_statistics`)."""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True, nogil=True)
def norm_residuals_kernel(theta, points, g):
    """r = ‖K⁻¹(m − b)‖ − g (m/s²) of each θ row of ``theta`` (M, 9) at each column of ``points`` (3, P) → (M, P):
    K⁻¹ by back substitution on the upper-triangular K in the order of :func:`optinav.multipos.model._solve_upper`
    (the same bits as the norms of :func:`~optinav.multipos.model.corrected`). A GA's population on every static
    sample (50 × 12 011) took 26 ms in numpy's temporaries, 2 ms here."""
    M, P = theta.shape[0], points.shape[1]
    out = np.empty((M, P))
    x, y, z = points[0], points[1], points[2]
    for m in range(M):
        kxx, kyy, kzz, kxy, kxz, kyz = theta[m, 0], theta[m, 1], theta[m, 2], theta[m, 3], theta[m, 4], theta[m, 5]
        bx, by, bz = theta[m, 6], theta[m, 7], theta[m, 8]
        row = out[m]
        for p in range(P):
            u2 = (z[p] - bz) / kzz
            u1 = ((y[p] - by) - kyz * u2) / kyy
            u0 = ((x[p] - bx) - kxy * u1 - kxz * u2) / kxx
            row[p] = math.sqrt(u0 * u0 + u1 * u1 + u2 * u2) - g
    return out


@numba.njit(cache=True, nogil=True)
def _kept(raw, valid, masked, i):
    """Row i is finite and, with a mask, valid."""
    ok = math.isfinite(raw[i, 0]) and math.isfinite(raw[i, 1]) and math.isfinite(raw[i, 2])
    return ok and (not masked or valid[i])


@numba.njit(cache=True, nogil=True)
def pose_moments_kernel(raw, ranges, valid):
    """Mean (P, 3), sample covariance (ddof 1, two passes: centred products) (P, 3, 3) and count (P,) of the rows
    of ``raw`` (N, 3) in each half-open range ``ranges`` (P, 2) (within [0, N]) that are finite and ``valid``
    (N,) bool (an empty array: every row). A count below 2 leaves its pose's moments NaN for the caller to refuse.
    numpy's per-pose mask, copy, mean and ``np.cov`` took 7 ms on 12 poses x 6000 samples."""
    P = ranges.shape[0]
    means = np.full((P, 3), np.nan)
    covs = np.full((P, 3, 3), np.nan)
    counts = np.zeros(P, np.int64)
    masked = valid.shape[0] > 0
    for k in range(P):
        i0, i1 = ranges[k, 0], ranges[k, 1]
        s0 = s1 = s2 = 0.0
        n = 0
        for i in range(i0, i1):
            if not _kept(raw, valid, masked, i):
                continue
            a, b, c = raw[i, 0], raw[i, 1], raw[i, 2]
            s0 += a
            s1 += b
            s2 += c
            n += 1
        counts[k] = n
        if n < 2:
            continue
        m0, m1, m2 = s0 / n, s1 / n, s2 / n
        c00 = c01 = c02 = c11 = c12 = c22 = 0.0
        for i in range(i0, i1):
            if not _kept(raw, valid, masked, i):
                continue
            a, b, c = raw[i, 0], raw[i, 1], raw[i, 2]
            a -= m0
            b -= m1
            c -= m2
            c00 += a * a
            c01 += a * b
            c02 += a * c
            c11 += b * b
            c12 += b * c
            c22 += c * c
        means[k, 0], means[k, 1], means[k, 2] = m0, m1, m2
        d = n - 1.0
        cv = covs[k]
        cv[0, 0], cv[1, 1], cv[2, 2] = c00 / d, c11 / d, c22 / d
        cv[0, 1] = cv[1, 0] = c01 / d
        cv[0, 2] = cv[2, 0] = c02 / d
        cv[1, 2] = cv[2, 1] = c12 / d
    return means, covs, counts
