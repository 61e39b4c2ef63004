"""Attitude estimators: throughput and accuracy of QN, GD, CG, MEKF beside ahrs's Madgwick on the same data.

Data: BROAD trial 02 (53 240 samples at 285.7 Hz, optical truth; $OPTINAV_SHARED_DATA or /work/shared/data)
if present, else a simulated dynamic flight (optinav.attitude.simulate). Throughput = samples per second of
the batch API ``optinav.attitude.estimate`` (best of several runs after a warm-up, numba compiled) on the
data tiled to ≥ 1 M samples; accuracy = BROAD inclination RMSE (movement samples, NaN rows excluded), gyro +
accelerometer only. ahrs (test extra) runs its Madgwick over the same arrays. Target (issue 6): QN batch
throughput ≥ 1 million samples/s.
"""

from __future__ import annotations

import time

import numpy as np

from optinav.attitude import estimate
from optinav.attitude.metrics import inclination_error, rmse


def _data(quick: bool):
    from optinav.attitude.data import BROAD_TRIAL_02, load_broad, shared_data_dir

    path = shared_data_dir() / BROAD_TRIAL_02
    if path.is_file():
        tr = load_broad(path)
        return "BROAD trial 02", "ENU", tr.gyr, tr.acc, tr.dt, tr.q_ref, tr.eval_mask
    from optinav.attitude.simulate import simulate_flight

    d = simulate_flight("dynamic", duration_s=60 if quick else 300, rng=1)
    return "simulated flight", d.frame, d.gyr, d.acc, d.dt, d.q_true, np.ones(len(d), bool)


def _best_time(fn, reps: int) -> float:
    best = np.inf
    for _ in range(reps):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def run(quick: bool) -> list[dict]:
    name, frame, gyr, acc, dt, q_ref, mask = _data(quick)
    n_target = 1_000_000
    k = int(np.ceil(n_target / gyr.shape[0]))
    big_g, big_a = np.tile(gyr, (k, 1)), np.tile(acc, (k, 1))
    rows = []
    group_t = f"attitude throughput ({name} tiled to {big_g.shape[0]} samples)"
    group_a = f"attitude accuracy ({name}, {gyr.shape[0]} samples, gyro+acc)"
    reps = 2 if quick else 5
    for method in ("qn", "gd", "cg", "mekf"):
        estimate(gyr[:100], acc[:100], dt, method=method, frame=frame)  # compile / load the numba cache
        t = _best_time(lambda: estimate(big_g, big_a, dt, method=method, frame=frame), reps)
        rows.append({"group": group_t, "method": f"optinav {method}", "metric": "throughput",
                     "value": big_g.shape[0] / t, "unit": "samples/s"})
        q = estimate(gyr, acc, dt, method=method, frame=frame)
        rows.append({"group": group_a, "method": f"optinav {method}", "metric": "inclination RMSE",
                     "value": float(np.degrees(rmse(inclination_error(q, q_ref), mask))), "unit": "deg"})
    try:
        import ahrs
    except ImportError:
        ahrs = None
    if ahrs is not None:
        rate = 1.0 / float(np.atleast_1d(dt)[0])
        n_ahrs = min(gyr.shape[0], 20_000 if quick else gyr.shape[0])  # pure Python: ~10 µs per sample
        t = _best_time(lambda: ahrs.filters.Madgwick(gyr=gyr[:n_ahrs], acc=acc[:n_ahrs], frequency=rate,
                                                     gain=0.033), 1)
        rows.append({"group": group_t, "method": "ahrs Madgwick (gain 0.033)", "metric": "throughput",
                     "value": n_ahrs / t, "unit": "samples/s"})
        q = ahrs.filters.Madgwick(gyr=gyr, acc=acc, frequency=rate, gain=0.033).Q
        rows.append({"group": group_a, "method": "ahrs Madgwick (gain 0.033)", "metric": "inclination RMSE",
                     "value": float(np.degrees(rmse(inclination_error(q, q_ref), mask))), "unit": "deg"})
    return rows
