"""Honesty of the reported accelerometer std: RMS(error/std) per parameter group over seeded Monte Carlo runs.

Every configuration of :data:`optinav.multipos.uncertainty.CONFIGS` (the models the CLI offers: full, diagonal
with held misalignments, six axis poses, a common bias offset given as --acc-bias-instability) with the same
seeds; target 0.8 … 1.25 (the 99 % band of a 100-run RMS ratio). The table is in docs/methods/multipos.md.
Run alone: ``python benchmarks/bench_multipos_uncertainty.py`` (prints the markdown table).
"""

from __future__ import annotations

from optinav.multipos import uncertainty


def run(quick: bool) -> list[dict]:
    n_runs = 100 if quick else 400
    rows = []
    for name, res in uncertainty.run_all(n_runs, rng=0).items():
        for group, value in res.items():
            rows.append({"group": f"accel std honesty, {n_runs} runs", "method": name,
                         "metric": f"RMS(error/std) {group}", "value": value, "unit": "(target 0.8-1.25)"})
    return rows


if __name__ == "__main__":
    print(uncertainty.table(uncertainty.run_all(400, rng=0)))
