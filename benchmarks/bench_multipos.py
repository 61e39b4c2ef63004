"""Accelerometer multi-position calibration: optinav's default vs the paper's GA and Newton (Gao & Zhang 2019).

Data: the paper's 12 positions, 6000 samples each (1 min at 100 Hz; quick: 1000), the paper's Table 2
accelerometer as truth, MTi-1 white noise (σ = 120 µg/√Hz·√100 Hz per sample). Timed from the raw samples:
the default (pose statistics + closed form + Levenberg–Marquardt on the pose means), the adaptive GA with the
paper's settings (population 50, 200 generations, fitness 1/E on every sample) and Newton on every sample.
Efficiency: RMSE/√CRLB of the default over Monte Carlo runs (≥ 200) on a D-optimal 12-pose scheme.
Targets (issue 3): default ≥ 1000× faster than the GA; efficiency ≤ 1.1.
"""

from __future__ import annotations

import time

import numpy as np

from optinav.multipos import accel, design, model
from optinav.multipos.simulate import PAPER_REFERENCE

G = 9.80167
SIGMA = 120e-6 * 9.80665 * 10.0  # m/s² per sample at 100 Hz


def _truth():
    return model.from_paper(
        PAPER_REFERENCE["S"],
        PAPER_REFERENCE["M_xy"],
        PAPER_REFERENCE["M_xz"],
        PAPER_REFERENCE["M_yz"],
        PAPER_REFERENCE["B"],
        G,
    )


def _session(n, rng):
    K, b = _truth()
    ups = design.PAPER_SCHEME_UP[:12]
    raws = [K @ (G * u) + b + rng.normal(0, SIGMA, (n, 3)) for u in ups]
    idx = np.array([[k * n, (k + 1) * n] for k in range(len(ups))])
    return np.concatenate(raws), idx, raws


def run(quick: bool) -> list[dict]:
    rng = np.random.default_rng(1)
    n = 1000 if quick else 6000
    raw, idx, raws = _session(n, rng)
    th_true = model.Kb_to_theta(*_truth())
    rows = []
    group = f"accel calibration, 12 poses x {n} samples"
    times = {}
    for name, kw in (
        ("optinav lm (means)", {}),
        ("paper GA (samples)", {"method": "ga", "data": "samples", "generations": 200, "population": 50}),
        ("Newton (samples)", {"method": "newton", "data": "samples"}),
    ):
        reps = 20 if name.startswith("optinav") else 1
        best = np.inf
        for _ in range(reps):
            t0 = time.perf_counter()
            st = accel.pose_statistics(raw, idx)
            extra = {"samples": raws} if kw.get("data") == "samples" else {}
            fit = accel.fit_accel(st, G, rng=7, **kw, **extra)
            best = min(best, time.perf_counter() - t0)
        times[name] = best
        err = (fit.theta - th_true) / np.where(fit.crlb_std > 0, fit.crlb_std, 1)
        rows += [
            {"group": group, "method": name, "metric": "time", "value": best, "unit": "s"},
            {
                "group": group,
                "method": name,
                "metric": "max |error|/sigma",
                "value": float(np.max(np.abs(err))),
                "unit": "",
            },
        ]
    rows.append(
        {
            "group": group,
            "method": "optinav lm (means)",
            "metric": "speed-up vs GA",
            "value": times["paper GA (samples)"] / times["optinav lm (means)"],
            "unit": "x (target >= 1000)",
        }
    )

    n_runs = 200 if quick else 1000
    K, b = _truth()
    ups = design.design_scheme(12, criterion="D").up_dirs
    eff, _ = accel.efficiency(K, b, ups, G, SIGMA, n, n_runs, rng)
    rows.append(
        {
            "group": f"efficiency, {n_runs} Monte Carlo runs",
            "method": "optinav lm (means)",
            "metric": "max RMSE/sqrt(CRLB)",
            "value": float(eff.max()),
            "unit": "(target <= 1.1)",
        }
    )
    rows.append(
        {
            "group": f"efficiency, {n_runs} Monte Carlo runs",
            "method": "optinav lm (means)",
            "metric": "min RMSE/sqrt(CRLB)",
            "value": float(eff.min()),
            "unit": "",
        }
    )
    return rows
