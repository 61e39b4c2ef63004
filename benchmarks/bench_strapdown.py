"""Strapdown throughput: numba attitude kernel vs a pure Python/numpy loop, and the full mechanization.

Rows (group "strapdown attitude <coning>" / "strapdown mechanize <coning>"): updates per second, best of 3
after a JIT warm-up, N = 10⁷ increments (quick: 10⁶); the Python reference runs on 2·10⁴ increments.
Throughput is counted in IMU samples (increments) per second, so multi-sample algorithms are comparable.
"""

from __future__ import annotations

import time

import numpy as np

from optinav.core import strapdown
from optinav.core.rotations import quat_from_rotvec, quat_multiply


def _reference_loop(q0, dtheta):
    """Textbook loop: one-sample + previous-sample coning, exact rotation-vector quaternion, renormalize."""
    q = np.asarray(q0, dtype=float)
    prev = np.zeros(3)
    out = np.empty((dtheta.shape[0] + 1, 4))
    out[0] = q
    for k, d in enumerate(dtheta):
        phi = d + np.cross(prev, d) / 12.0
        prev = d
        q = quat_multiply(q, quat_from_rotvec(phi))
        q = q / np.linalg.norm(q)
        out[k + 1] = q
    return out


def _best(fn, repeat=3):
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def run(quick: bool) -> list[dict]:
    n = 10**6 if quick else 10**7
    rng = np.random.default_rng(0)
    dth = rng.normal(0.0, 1e-3, (n, 3))
    dv = rng.normal(0.0, 1e-3, (n, 3)) + np.array([0.0, 0.0, 9.8 * 0.01])
    t = np.arange(n + 1) * 0.01
    q0 = np.array([1.0, 0.0, 0.0, 0.0])
    w_in = np.array([0.0, 5.2e-5, 5.2e-5])
    rows = []

    def row(group, method, value, unit="updates/s", metric="throughput"):
        rows.append({"group": group, "method": method, "metric": metric, "value": float(value), "unit": unit})

    n_ref = 20_000
    ref_rate = n_ref / _best(lambda: _reference_loop(q0, dth[:n_ref]), repeat=1)
    for coning in strapdown.CONING_ALGORITHMS:
        group = f"strapdown attitude {coning}"
        strapdown.attitude_update(q0, dth[:16], coning=coning)  # JIT warm-up (or cache load)
        strapdown.attitude_update(q0, dth[:16], coning=coning, final_only=True)
        strapdown.attitude_update(q0, dth[:16], coning=coning, omega_in_n=w_in, dt=0.01)
        row(group, "numba, history", n / _best(lambda: strapdown.attitude_update(q0, dth, coning=coning)))
        row(
            group,
            "numba, final only",
            n / _best(lambda: strapdown.attitude_update(q0, dth, coning=coning, final_only=True)),
        )
        row(
            group,
            "numba, history + nav-frame rate",
            n / _best(lambda: strapdown.attitude_update(q0, dth, coning=coning, omega_in_n=w_in, dt=0.01)),
        )
        if coning == "previous":
            row(group, f"python/numpy loop (N={n_ref})", ref_rate)
    n_mech = n // 10 if quick else n
    for coning in ("none", "previous", "two-sample", "four-sample"):
        group = f"strapdown mechanize {coning}"
        args = (q0, np.zeros(3), np.array([np.radians(45.0), 0.0, 0.0]))
        strapdown.mechanize(dth[:16], dv[:16], t[:17], *args, frame="enu", coning=coning)
        rate = n_mech / _best(
            lambda: strapdown.mechanize(dth[:n_mech], dv[:n_mech], t[: n_mech + 1], *args, frame="enu", coning=coning)
        )
        row(group, f"numba mechanize (N={n_mech})", rate)
    return rows


if __name__ == "__main__":
    import sys

    for r in run("--quick" in sys.argv):
        print(f"{r['group']:<36} {r['method']:<38} {r['value']:>14.4g} {r['unit']}")
