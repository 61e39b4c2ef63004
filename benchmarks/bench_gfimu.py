"""Gyro-free array turntable calibration (Hao & Liu 2011): paper's closed form vs optinav's default.

Setup: cylinder10, Δr = 1 mm on every axis, Δα = Δβ = 0.01 rad, noise 1 µg, wedge 30°, 100 Hz.
Rows: max relative error of the 30 position coefficients at 0.1/0.2 and 0.5/1.0 rad/s for the closed form
with one sample per case (the paper's setting) and with N samples per case, and for the default LM with N
samples (targets, issue 5 item 9: ≤ 20 % and ≤ 1 %); run time; RMSE/√CRLB of the LM over Monte Carlo runs.
"""

from __future__ import annotations

import time

import numpy as np

from optinav.gfimu import (
    RATE_METHODS,
    InstallationErrors,
    builtin,
    calibrate,
    closed_form,
    coning_motion,
    simulate,
    solve_rate,
)
from optinav.gfimu.turntable import PAPER


def run(quick: bool) -> list[dict]:
    rng = np.random.default_rng(11)
    arr = builtin()
    err = InstallationErrors.uniform(10)
    truth = err.vector()
    n = 1000
    n_mc = 30 if quick else 200
    rows = []
    for key, rates in PAPER["rates"].items():
        group = f"gfimu turntable {rates[0]}/{rates[1]} rad/s, 1 µg"
        target = 20.0 if key == "low" else 1.0
        res_cf1, res_cf, res_lm, t_cf, t_lm, est, crlb = [], [], [], [], [], [], None
        for _ in range(n_mc):
            d1 = simulate(arr, err, rates=rates, duration=0.01, rng=rng)
            res_cf1.append(np.abs((closed_form(arr, d1).vector() - truth) / truth).reshape(-1, 5)[:, :3].max())
            d = simulate(arr, err, rates=rates, duration=n / 100.0, rng=rng)
            t0 = time.perf_counter()
            cf = closed_form(arr, d).vector()
            t_cf.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            lm = calibrate(arr, d, offset="zero", sigma=PAPER["noise"])
            t_lm.append(time.perf_counter() - t0)
            res_cf.append(np.abs((cf - truth) / truth).reshape(-1, 5)[:, :3].max())
            res_lm.append(np.abs((lm.estimate - truth) / truth).reshape(-1, 5)[:, :3].max())
            est.append(lm.estimate)
            crlb = lm.crlb_std
        eff = np.sqrt(np.mean((np.array(est) - truth) ** 2, axis=0)) / crlb
        rows += [
            {
                "group": group,
                "method": "paper closed form, 1 sample/case",
                "metric": "max rel. error position (median of runs)",
                "value": float(np.median(res_cf1)) * 100,
                "unit": f"% (paper {PAPER['max_rel_err_position_pct'][key]})",
            },
            {
                "group": group,
                "method": f"closed form, {n} samples/case",
                "metric": "max rel. error position (median of runs)",
                "value": float(np.median(res_cf)) * 100,
                "unit": "%",
            },
            {
                "group": group,
                "method": f"optinav lm, {n} samples/case",
                "metric": "max rel. error position (median of runs)",
                "value": float(np.median(res_lm)) * 100,
                "unit": f"% (target <= {target})",
            },
            {
                "group": group,
                "method": f"optinav lm, {n} samples/case",
                "metric": "max rel. error position (worst run)",
                "value": float(np.max(res_lm)) * 100,
                "unit": "%",
            },
            {"group": group, "method": "closed form", "metric": "time", "value": float(np.median(t_cf)), "unit": "s"},
            {"group": group, "method": "optinav lm", "metric": "time", "value": float(np.median(t_lm)), "unit": "s"},
            {
                "group": group,
                "method": "optinav lm",
                "metric": f"max RMSE/sqrt(CRLB), {n_mc} runs",
                "value": float(eff.max()),
                "unit": "",
            },
            {
                "group": group,
                "method": "optinav lm",
                "metric": f"min RMSE/sqrt(CRLB), {n_mc} runs",
                "value": float(eff.min()),
                "unit": "",
            },
        ]
    # rate solvers: time per 10⁴ epochs and accuracy on coning with 1e-4 m/s² noise (is numba needed?)
    mot = coning_motion(100.0, 0.01)
    f = arr.outputs(mot.A, mot.wdot, mot.omega) + rng.normal(0, 1e-4, (len(mot.t), arr.n))
    for meth in RATE_METHODS:
        t0 = time.perf_counter()
        w = solve_rate(arr, f, mot.t, mot.omega[0], meth)
        el = time.perf_counter() - t0
        g = "gfimu rate solvers, cylinder10, coning 100 s at 100 Hz, 1e-4 m/s²"
        rows += [
            {"group": g, "method": meth, "metric": "time per 1e4 epochs", "value": el / len(mot.t) * 1e4, "unit": "s"},
            {
                "group": g,
                "method": meth,
                "metric": "RMS rate error",
                "value": float(np.sqrt(np.mean((w - mot.omega) ** 2))),
                "unit": "rad/s",
            },
        ]
    return rows
