"""Compiled interleave of three sample columns into an (n, 3) row-major triad, with its value range.

numpy's strided store (``column_stack``) and the separate min and max passes of the reader's value check cost
about three passes over a triad; this is one (numba, ``cache=True``). A triad already in one array takes numpy's
min and max (vectorized: faster than a scalar pass). Used by :func:`optinav.io.imu._triad` for
long columns only, so a small file never waits for numba's start.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, nogil=True)
def interleave3(a, b, c, out):
    """Write ``a``, ``b``, ``c`` (n,) into the columns of ``out`` (n, 3); return (min, max) of every value, both
    NaN when any value is NaN."""
    lo, hi, nan = np.inf, -np.inf, False
    for i in range(a.shape[0]):
        x, y, z = a[i], b[i], c[i]
        out[i, 0], out[i, 1], out[i, 2] = x, y, z
        for v in (x, y, z):
            if v < lo:
                lo = v
            if v > hi:
                hi = v
            nan |= v != v
    if nan:
        return np.nan, np.nan
    return lo, hi
