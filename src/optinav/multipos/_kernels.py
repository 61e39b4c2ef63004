"""numba kernel of the norm observation (private; the numpy API is :func:`optinav.multipos.model.norm_residuals`)."""

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
