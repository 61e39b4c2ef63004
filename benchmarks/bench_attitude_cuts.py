"""9D heading on BROAD recordings that start in motion: every trial cut to start some seconds after its motion.

Data: every BROAD trial in ``../shared/data/attitude/broad`` ($OPTINAV_SHARED_DATA; Laidig et al. 2021, CC BY
4.0). Each trial is cut to start ``START_S`` seconds (10, 30, 60) after its first movement sample and to end 10 s
before its last, so the recording has no rest at either end (the whole trials start and end at rest, where the
gyro bias is learned). Rows, per trial and mean per start: heading RMSE (BROAD metric, movement samples with a
valid optical reference) of optinav iframe online 9D and offline 9D (default options) and, with the ``bench``
extra, VQF 2.x offline 9D (``offlineVQF``, defaults). ``python benchmarks/bench_attitude_cuts.py [--starts
10,30,60] [--json FILE]`` (progress on stderr).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

import numpy as np

from optinav.attitude import estimate_q
from optinav.attitude.data import load_broad
from optinav.attitude.metrics import heading_error, rmse

#: the shared data folder: ../shared/data relative to the project root ($OPTINAV_SHARED_DATA overrides)
SHARED = Path(os.environ.get("OPTINAV_SHARED_DATA", Path(__file__).resolve().parents[1] / ".." / "shared" / "data"))

START_S = (10.0, 30.0, 60.0)  # s after the first movement sample
END_S = 10.0  # s before the last movement sample


def cut(trial, start_s: float, end_s: float = END_S) -> slice:
    """Samples of ``trial`` from ``start_s`` s after its first movement sample to ``end_s`` s before its last."""
    mv = np.flatnonzero(trial.eval_mask)
    return slice(int(mv[0] + start_s / trial.dt), int(mv[-1] - end_s / trial.dt))


def _methods() -> dict:
    """name → fn(gyr, acc, mag, dt) -> q (N, 4) body → ENU."""
    m = {
        "optinav iframe 9D": lambda g, a, mg, dt: estimate_q(g, a, dt, frame="ENU", mag=mg, checks=False),
        "optinav iframe offline 9D": lambda g, a, mg, dt: estimate_q(
            g, a, dt, frame="ENU", mag=mg, offline=True, checks=False
        ),
    }
    try:
        import vqf
    except ImportError:
        print("vqf absent (pip install '.[bench]'): its row is left out", file=sys.stderr)
    else:
        c = np.ascontiguousarray
        m["vqf offline 9D"] = lambda g, a, mg, dt: vqf.offlineVQF(c(g), c(a), c(mg), dt)["quat9D"]
    return m


def run(starts=START_S) -> list[dict]:
    """Rows {start_s, method, trial → heading RMSE (deg), mean}."""
    folder = SHARED / "attitude" / "broad"
    paths = sorted(p for p in folder.glob("[0-9][0-9]_*") if p.suffix in (".hdf5", ".mat"))
    trials = {p.stem[:2]: load_broad(p) for p in paths}
    methods = _methods()
    rows = []
    for s0 in starts:
        for name, fn in methods.items():
            print(f"  +{s0:g} s: {name}", file=sys.stderr)
            row = {"start_s": s0, "method": name}
            for key, tr in trials.items():
                sl = cut(tr, s0)
                q = fn(tr.gyr[sl], tr.acc[sl], tr.mag[sl], tr.dt)
                row[key] = float(np.degrees(rmse(heading_error(q, tr.q_ref[sl]), tr.eval_mask[sl])))
            row["mean"] = float(np.mean([row[k] for k in trials]))
            rows.append(row)
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--starts", default=",".join(f"{s:g}" for s in START_S), help="s after the first motion")
    ap.add_argument("--json", default=None, help="write the rows as JSON")
    args = ap.parse_args(argv)
    rows = run([float(x) for x in args.starts.split(",")])
    keys = [k for k in rows[0] if k not in ("start_s", "method")]
    print("| start | method | " + " | ".join(keys) + " |")
    print("|---|---|" + "---|" * len(keys))
    for r in rows:
        print(f"| +{r['start_s']:g} s | {r['method']} | " + " | ".join(f"{r[k]:.3f}" for k in keys) + " |")
    if args.json:
        Path(args.json).write_text(json.dumps({"rows": rows}, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
