"""Honesty of the reported accelerometer std: RMS(error/std) per parameter group over seeded Monte Carlo runs.

Every configuration of :data:`optinav.multipos.uncertainty.CONFIGS` (the models the CLI offers: full, diagonal
with held misalignments, six axis poses, a common bias offset given as --acc-bias-instability) with the same
seeds, and the gyro (100 full simulated sessions each; "scale" there is all of K) with an unmodelled
g-sensitivity, with a bias that drifts in the run (the bias error against the session's bias, or the long-term
bias when --gyro-bias-instability is given) and with every --gyro-bias mode; target 0.8 … 1.25 (the 99 % band of a 100-run RMS ratio).
The table is in docs/methods/multipos.md. Run alone: ``python benchmarks/bench_multipos_uncertainty.py [JSON]``
(prints the markdown table; writes the figures to JSON, benchmarks/multipos_uncertainty.json is the committed run).
"""

from __future__ import annotations

from optinav.multipos import uncertainty


def run(quick: bool) -> list[dict]:
    n_runs = 100 if quick else 400
    rows = []
    results = uncertainty.run_all(n_runs, rng=0)
    n_gyro = 10 if quick else 100
    results.update(uncertainty.gyro_g_sensitivity_study(n_gyro, rng=0))
    results.update(uncertainty.gyro_drift_study(n_gyro, rng=0))
    for name, res in results.items():
        for group, value in res.items():
            if value is None:
                continue
            n = n_gyro if name.startswith("gyro") else n_runs
            rows.append(
                {
                    "group": f"{'gyro' if name.startswith('gyro') else 'accel'} std honesty, {n} runs",
                    "method": name,
                    "metric": f"RMS(error/std) {group}",
                    "value": value,
                    "unit": "(target 0.8-1.25)",
                }
            )
    return rows


if __name__ == "__main__":
    import json
    import platform
    import sys
    import time

    t0 = time.perf_counter()
    rows = run(quick=False)
    res: dict = {}
    for r in rows:
        res.setdefault(r["method"], {"scale": None, "misalignment": None, "bias": None})[r["metric"].split()[-1]] = r[
            "value"
        ]
    print(uncertainty.table(res))
    if len(sys.argv) > 1:
        meta = {
            "python": platform.python_version(),
            "machine": platform.machine(),
            "quick": False,
            "date": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
            "elapsed_s": round(time.perf_counter() - t0, 1),
        }
        with open(sys.argv[1], "w") as fh:
            fh.write(json.dumps({"meta": meta, "rows": rows}, indent=2) + "\n")
